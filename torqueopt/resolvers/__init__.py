"""The registry of resolvers, by name.

====================== ==========================================================
name                   method (equation of the paper)
====================== ==========================================================
``pinv``               unweighted pseudoinverse, Eq. (34)
``inertia-pinv``       inertia-weighted pseudoinverse, Eqs. (16), (35)
``null-space``         null-space torque optimisation, Eqs. (28)-(31), (36)
``weighted-null-space`` the same weighted by torque range, Eqs. (33), (37)
====================== ==========================================================
"""

from __future__ import annotations

from ..errors import ResolverNotFound
from .base import Resolution, Resolver
from .null_space import NullSpaceTorque, WeightedNullSpaceTorque
from .pseudoinverse import InertiaWeightedPseudoInverse, PseudoInverse

__all__ = [
    "Resolution",
    "Resolver",
    "PseudoInverse",
    "InertiaWeightedPseudoInverse",
    "NullSpaceTorque",
    "WeightedNullSpaceTorque",
    "RESOLVERS",
    "get_resolver",
    "resolver_names",
]

RESOLVERS: dict[str, type[Resolver]] = {
    cls.name: cls for cls in (PseudoInverse, InertiaWeightedPseudoInverse, NullSpaceTorque, WeightedNullSpaceTorque)
}


def resolver_names() -> list[str]:
    """Names of the registered resolvers, in the paper's order."""
    return list(RESOLVERS)


def get_resolver(resolver: str | Resolver, **options) -> Resolver:
    """A resolver object from its registered name (options go to its constructor), or the object itself."""
    if isinstance(resolver, Resolver):
        return resolver
    try:
        cls = RESOLVERS[resolver]
    except (KeyError, TypeError):
        raise ResolverNotFound(f"unknown resolver '{resolver}': choose one of {', '.join(RESOLVERS)}") from None
    return cls(**options)

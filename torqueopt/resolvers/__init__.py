"""The registry of resolvers, by name.

Each resolver's equations of the paper, cited the same way in its module
docstring, at the lines that compute them, and in the table of docs/resolvers/index.md:

==================================== ==================================================================== ================================================
name                                 method                                                               equations of the paper
==================================== ==================================================================== ================================================
``pinv``                             unweighted pseudoinverse                                             Eq. (34)
``inertia-pinv``                     inertia-weighted pseudoinverse                                       Eq. (16), Eq. (19), Eq. (35)
``null-space``                       null-space torque optimisation                                       Eq. (28), Eq. (29), Eq. (30), Eq. (31), Eq. (36)
``weighted-null-space``              the same, weighted by torque range                                   Eq. (32), Eq. (33), Eq. (37)
``damped-null-space``                the torque criterion plus a self-motion damping term                 the Discussion; S of Eq. (33)
``self-motion-damping``              y = −K_D Zᵀq̇, the kinematic limit of the blend                      (not in the paper)
``inverse-inertia-torque``           minimum τᵀH⁻¹τ (Gauss's principle)                                   (not in the paper)
``inverse-inertia-squared-torque``   minimum τᵀH⁻²τ                                                       (not in the paper)
``bounded-torque``                   the torque criterion under hard bounds τ⁻ <= τ <= τ⁺ (a QP)          Eq. (26), Eq. (29), Eq. (33), the Discussion
``minmax-torque``                    the least largest normalised torque (an LP)                          Eq. (26), Eq. (28), the Discussion
``gradient-projection-acceleration`` Liégeois's gradient as a null-space acceleration, self-motion damped Eq. (4), criteria Eq. (5), Eq. (6)
``task-priority-acceleration``       task priority at the acceleration level                              Eq. (11) differentiated
``energy-bounded-torque``            the torque criterion under torque bounds and a self-motion energy    Eq. (26), Eq. (29), Eq. (33)
                                     barrier (a QP)
==================================== ==================================================================== ================================================

All of them write the joint acceleration as Eq. (26) and the torque as
Eq. (20) (:class:`~torqueopt.resolvers.base.NullSpaceResolver`).

The last two are the acceleration-level forms of Section 1.1 methods, from
:mod:`torqueopt.resolvers.second_order`. The velocity-level methods of
Section 1.1 (``velocity-pinv``, ``gradient-projection``, ``task-priority``,
``obstacle-avoidance``, ``extended-jacobian``, ``kinetic-energy-pinv``) are
registered too, from :mod:`torqueopt.resolvers.velocity` (their table is
there); their ``level`` is ``"velocity"``. Each resolver's :attr:`equations`
lists the same numbers as its row.
"""

from __future__ import annotations

import difflib

from ..errors import InvalidInput, ResolverNotFound
from .base import NullSpaceResolver, Resolution, Resolver, Step
from .bounded import BoundedTorque, EnergyBoundedTorque, MinMaxTorque
from .damping import DampedNullSpaceTorque, SelfMotionDamping
from .inverse_inertia import InverseInertiaSquaredTorque, InverseInertiaTorque
from .null_space import NullSpaceTorque, WeightedNullSpaceTorque
from .options import Option, parse_resolver_spec
from .pseudoinverse import InertiaWeightedPseudoInverse, PseudoInverse
from .second_order import GradientProjectionAcceleration, TaskPriorityAcceleration
from .velocity import VELOCITY_RESOLVERS

__all__ = [
    "Resolution",
    "Resolver",
    "NullSpaceResolver",
    "Step",
    "Option",
    "PseudoInverse",
    "InertiaWeightedPseudoInverse",
    "NullSpaceTorque",
    "WeightedNullSpaceTorque",
    "DampedNullSpaceTorque",
    "SelfMotionDamping",
    "InverseInertiaTorque",
    "InverseInertiaSquaredTorque",
    "BoundedTorque",
    "MinMaxTorque",
    "EnergyBoundedTorque",
    "RESOLVERS",
    "get_resolver",
    "resolver_from_label",
    "resolver_names",
]

RESOLVERS: dict[str, type[Resolver]] = {
    cls.name: cls
    for cls in (
        PseudoInverse,
        InertiaWeightedPseudoInverse,
        NullSpaceTorque,
        WeightedNullSpaceTorque,
        DampedNullSpaceTorque,
        SelfMotionDamping,
        InverseInertiaTorque,
        InverseInertiaSquaredTorque,
        BoundedTorque,
        MinMaxTorque,
        EnergyBoundedTorque,
    )
}
RESOLVERS.update((cls.name, cls) for cls in VELOCITY_RESOLVERS)
RESOLVERS.update((cls.name, cls) for cls in (GradientProjectionAcceleration, TaskPriorityAcceleration))


def resolver_names(level: str | None = None) -> list[str]:
    """Names of the registered resolvers, the paper's first.

    Args:
        level: ``"torque"`` for those that map a task acceleration to torques
            (a step of :func:`torqueopt.resolve`), ``"velocity"`` for the
            kinematic ones of Section 1.1; None for all.
    """
    if level is None:
        return list(RESOLVERS)
    if level not in ("torque", "velocity"):
        raise InvalidInput(f"unknown resolver level '{level}': choose torque or velocity")
    return [name for name, cls in RESOLVERS.items() if getattr(cls, "level", "torque") == level]


def get_resolver(resolver: str | Resolver, **options) -> Resolver:
    """A resolver object from its registered name with ``options`` (its declared options), or the object itself.

    Raises:
        ResolverNotFound: no resolver has that name (the message lists those that exist).
        InvalidInput: an option the resolver does not declare, or a value it refuses;
            or options given with a Resolver object (set them when making the object).
    """
    if isinstance(resolver, Resolver):
        if options:
            raise InvalidInput(
                f"options {', '.join(options)} given with a {type(resolver).__name__} object; "
                f"set them when making it, or give the resolver's name '{resolver.name}'"
            )
        return resolver
    try:
        cls = RESOLVERS[resolver]
    except (KeyError, TypeError):
        close = difflib.get_close_matches(str(resolver), list(RESOLVERS), n=1, cutoff=0.7)
        hint = f" (did you mean '{close[0]}'?)" if close else ""
        raise ResolverNotFound(f"unknown resolver '{resolver}'{hint}: choose one of {', '.join(RESOLVERS)}") from None
    return cls(**options)


def resolver_from_label(spec: str | Resolver) -> Resolver:
    """A resolver from ``NAME`` or ``NAME[OPTION=VALUE,...]`` (its :attr:`~Resolver.label`), or the object itself.

    ``resolver_from_label("bounded-torque[joint_limits=off,damping=2]")`` is
    ``get_resolver("bounded-torque", joint_limits="off", damping="2")``: the
    values are checked by the resolver's own options.

    Raises:
        ResolverNotFound: no resolver has that name.
        InvalidInput: text not of that form, or an option or value the resolver refuses.
    """
    if isinstance(spec, Resolver):
        return spec
    name, options = parse_resolver_spec(spec)
    return get_resolver(name, **options)

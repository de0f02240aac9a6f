"""The registry of resolvers, by name (:mod:`torqueopt.resolvers.registry`: ``@register_resolver`` and entry points).

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
``receding-horizon``                 the torque criterion integrated over a moving window, under bounds   Eq. (20), Eq. (26), Eq. (29)
                                     and joint limits (predictive control, an NLP per window)
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

from ..errors import InvalidInput
from .base import NullSpaceResolver, Program, Resolution, Resolver, Step
from .bounded import BoundedTorque, EnergyBoundedTorque, MinMaxTorque
from .damping import DampedNullSpaceTorque, SelfMotionDamping
from .inverse_inertia import InverseInertiaSquaredTorque, InverseInertiaTorque
from .null_space import NullSpaceTorque, WeightedNullSpaceTorque
from .options import Option, parse_resolver_spec
from .pseudoinverse import InertiaWeightedPseudoInverse, PseudoInverse
from .receding_horizon import RecedingHorizon
from .registry import ENTRY_POINT_GROUP, RESOLVERS, class_from_path, register_resolver
from .second_order import GradientProjectionAcceleration, TaskPriorityAcceleration

__all__ = [
    "Program",
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
    "RecedingHorizon",
    "GradientProjectionAcceleration",
    "TaskPriorityAcceleration",
    "ENTRY_POINT_GROUP",
    "RESOLVERS",
    "register_resolver",
    "get_resolver",
    "resolver_from_label",
    "resolver_names",
]

# The order the listing, the help and the "choose one of ..." messages give: the paper's four first, then by
# family, as the tables. Each class registers itself where it is defined (the velocity-level ones when
# .second_order imports .velocity); plug-ins follow, in the order they come.
RESOLVERS.put_first(
    (
        "pinv",
        "inertia-pinv",
        "null-space",
        "weighted-null-space",
        "damped-null-space",
        "self-motion-damping",
        "inverse-inertia-torque",
        "inverse-inertia-squared-torque",
        "bounded-torque",
        "minmax-torque",
        "energy-bounded-torque",
        "receding-horizon",
        "velocity-pinv",
        "gradient-projection",
        "task-priority",
        "obstacle-avoidance",
        "extended-jacobian",
        "kinetic-energy-pinv",
        "gradient-projection-acceleration",
        "task-priority-acceleration",
    )
)


def resolver_names(level: str | None = None) -> list[str]:
    """Names of the registered resolvers, the paper's first (plug-ins included).

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


def get_resolver(resolver: str | type | Resolver, **options) -> Resolver:
    """A resolver object from its name, spec or class, with ``options`` (its declared options); or the object itself.

    ``resolver`` may be

    * a registered name, ``"bounded-torque"`` (``torqueopt.resolvers.RESOLVERS``: the built-in ones, ``@register_resolver``,
      entry points of the group ``torqueopt.resolvers``);
    * an import path, ``"mypkg.module:MyResolver"``: the class is imported, not registered;
    * either with options, ``"bounded-torque[joint_limits=off,damping=2]"`` (text, checked by the resolver's
      own options, as ``--resolver`` on the command line);
    * a :class:`Resolver` subclass, or a Resolver object (then without ``options``).

    Raises:
        ResolverNotFound: no resolver has that name (the message lists those that exist), the import path
            does not lead to a Resolver class, or the name's entry point failed to load (the message says which).
        InvalidInput: an option the resolver does not declare, or a value it refuses; an option given both in
            brackets and as a keyword; or options given with a Resolver object (set them when making the object).
    """
    if isinstance(resolver, Resolver):
        if options:
            raise InvalidInput(
                f"options {', '.join(options)} given with a {type(resolver).__name__} object; "
                f"set them when making it, or give the resolver's name '{resolver.name}'"
            )
        return resolver
    if isinstance(resolver, type) and issubclass(resolver, Resolver):
        return resolver(**options)
    if not isinstance(resolver, str):
        return RESOLVERS.lookup(resolver)  # raises, listing the names
    name, given = parse_resolver_spec(resolver)
    both = sorted(set(given) & set(options))
    if both:
        raise InvalidInput(f"resolver '{resolver}' gives option {', '.join(both)} again as a keyword; give it once")
    cls = class_from_path(name) if ":" in name else RESOLVERS.lookup(name)
    return cls(**given, **options)


def resolver_from_label(spec: str | Resolver) -> Resolver:
    """A resolver from ``NAME`` or ``NAME[OPTION=VALUE,...]`` (its :attr:`~Resolver.label` or
    :attr:`~Resolver.spec`), or the object itself.

    ``resolver_from_label("bounded-torque[joint_limits=off,damping=2]")`` is
    ``get_resolver("bounded-torque", joint_limits="off", damping="2")``: the
    values are checked by the resolver's own options. NAME may be an import path, ``mypkg.module:MyResolver``.

    Raises:
        ResolverNotFound: no resolver has that name.
        InvalidInput: text not of that form, or an option or value the resolver refuses.
    """
    return get_resolver(spec)

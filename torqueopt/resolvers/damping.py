r"""Remedies for the whiplash that weight the torque criterion with a kinematic term.

The paper's Discussion asks whether "the local optimization criterion" can be
weighted "with a kinematic term to avoid high velocity buildup". Two
resolvers answer it, both members of the null-space family
:math:`\ddot q = J^\dagger(\ddot x - \dot J\dot q) + Z y` (Eq. (26)):

``self-motion-damping``
    :math:`y = -K_D Z^\top \dot q`, i.e.

    .. math::

        \ddot q = J^\dagger(\ddot x - \dot J\dot q) - K_D\, Z Z^\top \dot q,

    null-space velocity damping as in De Luca, Oriolo & Siciliano, "Robot
    redundancy resolution at the acceleration level", Laboratory Robotics and
    Automation 4(2):97-108, 1992, and Hsu, Hauser & Sastry, "Dynamic control
    of redundant manipulators", J. Robotic Systems 6(2):133-148, 1989 (whose
    self-motion follows the projection of a chosen vector field; here the
    field is :math:`-K_D\dot q`). No torque criterion at all: a kinematic method.

``damped-null-space``
    the paper's torque criterion blended with that kinematic term,

    .. math::

        \min_y\ \|S(\tau - \tau_{mid})\|^2 + \bar\mu^2\,\|y + K_D Z^\top\dot q\|^2,
        \qquad \tau = \tilde\tau + H Z y \quad\text{(Eq. (27), Eq. (28), Eq. (29))},

    with :math:`S` the identity (``null-space``, Eq. (29)) or the torque-range
    weight :math:`S = \mathrm{diag}(1/(\tau^+_i - \tau^-_i))` of Eq. (33), or a
    user diagonal. :math:`\bar\mu = 0` is ``null-space`` / ``weighted-null-space``
    exactly; :math:`\bar\mu \to \infty` is ``self-motion-damping``.

Units and normalisation. :math:`S(\tau - \tau_{mid})` is in N·m (or is
dimensionless with the range weight) while :math:`y` is an acceleration
[rad/s²], so an absolute :math:`\bar\mu` would carry units of N·m/(rad/s²)
and its good value would change with the robot's size. The option
``kinematic_weight`` is therefore the dimensionless :math:`\mu` in

.. math::

    \bar\mu = \mu\, \|S H Z\|_F,

the kinematic term measured against the torque change a unit null-space
acceleration costs at this state (for one redundant degree of freedom
:math:`\|S H Z\|_F` is the only singular value of :math:`S H Z`). With
:math:`\mu = 1` a null-space acceleration away from the damped one costs as
much as the torque it could save along the strongest direction. Both terms
then scale alike with the robot's inertia and the weight, so one default
serves any arm.

The defaults, μ = 0.5 and K_D = 10 1/s, come from a sweep on the paper's
arm (see ``DEFAULT_DAMPING``); the remedies study of ``torqueopt paper``
(``torqueopt.studies.remedies``) reruns it and reports the trade-off.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InvalidInput, NoRedundancy
from ..linalg import LeastSquares
from ..robot import Robot, TaskTerms
from .base import NullSpaceFunction, NullSpaceResolver, joint_acceleration_of, null_space_projector
from .null_space import torque_midpoint
from .options import LARGEST_WEIGHT, Option, choice_or_vector, number
from .registry import register_resolver
from .stacks import least_squares

__all__ = [
    "SelfMotionDamping",
    "DampedNullSpaceTorque",
    "DEFAULT_DAMPING",
    "DEFAULT_KINEMATIC_WEIGHT",
    "torque_weight_root",
]

#: K_D [1/s] for both resolvers, and μ (dimensionless, relative to ‖S H Z‖_F) for
#: ``damped-null-space``. Chosen by sweeping μ ∈ {0.1, 0.15, 0.2, 0.3, 0.5, 0.7} × K_D ∈
#: {2, 5, 10, 15, 20, 30, 50} 1/s on the paper's arm, with both torque weights (``unit`` and
#: ``range``): (0.5, 10) is the setting that, with either weight, keeps the long (2 s) movement
#: stable and within its torque limits (peak |τ|/limit 0.94 with ``unit``, 0.83 with ``range``)
#: while keeping 91 % of the short (0.5 s) movement's cut in ∫‖S τ‖² dt that null-space /
#: weighted-null-space make against pinv. A smaller μ fails with the range weight (μ = 0.3,
#: K_D = 10 goes unstable on the long movement); a larger one gives up more of the cut (μ = 0.7
#: keeps 79 %). On one redundant degree of freedom the blend is the convex combination
#: y = (y_torque + μ² y_damping)/(1 + μ²), so the short movement, which starts at rest, keeps
#: about 1 − (μ²/(1 + μ²))² of the cut whatever the weight. ``examples/remedies_sweep.py``
#: reruns this sweep (``--torque-weight range`` or ``unit``); ``torqueopt paper`` runs a coarser one.
DEFAULT_DAMPING = 10.0
DEFAULT_KINEMATIC_WEIGHT = 0.5

_DAMPING_OPTION = Option(
    name="damping",
    kind="number in [0, 1e6]",
    unit="1/s",
    default=DEFAULT_DAMPING,
    meaning="K_D: the self-motion velocity Zᵀq̇ is driven towards zero at this rate",
    convert=number(0.0, unit="1/s", maximum=LARGEST_WEIGHT),
)


def torque_weight_root(torque_weight, robot: Robot, resolver: str) -> np.ndarray:
    """The diagonal of S (S² = W) [1/(N·m)] of a ``torque_weight`` option: ones for ``unit``, 1/(τ⁺ − τ⁻) for
    ``range`` (0 for an unbounded joint), or √w for a vector w of n non-negative numbers; else InvalidInput."""
    if isinstance(torque_weight, str):
        if torque_weight == "unit":
            return np.ones(robot.nv)
        torque_range = robot.torque_upper - robot.torque_lower
        return np.where(np.isfinite(torque_range), 1.0 / torque_range, 0.0)  # Eq. (33)
    if torque_weight.shape != (robot.nv,) or (torque_weight < 0).any():
        raise InvalidInput(
            f"option torque_weight={','.join(f'{w:g}' for w in torque_weight)} of resolver '{resolver}' must be "
            f"'unit', 'range' or {robot.nv} non-negative numbers, one per joint of robot '{robot.name}' "
            "(the diagonal of W)"
        )
    return np.sqrt(torque_weight)


@register_resolver
class SelfMotionDamping(NullSpaceResolver):
    r"""Null-space velocity damping: q̈ = J⁺(ẍ − J̇q̇) − K_D Z Zᵀ q̇ (De Luca, Oriolo & Siciliano 1992).

    With :math:`Z` an orthonormal null-space basis, :math:`Z Z^\top = I - J^\dagger J`,
    so this is :math:`\ddot q = J^\dagger(\ddot x - \dot J\dot q) - K_D (I - J^\dagger J)\dot q`:
    the pseudoinverse (Eq. (34)) plus a null-space acceleration that opposes the
    self-motion velocity. Along a fixed null space the self-motion coordinates
    obey :math:`\tfrac{d}{dt}(Z^\top\dot q) = -K_D Z^\top\dot q + \dot Z^\top\dot q`;
    the self-motion decays at rate :math:`K_D` [1/s] up to the turning of the
    null space. It ignores the torques: the kinematic end of the blend
    ``damped-null-space``.
    """

    name = "self-motion-damping"
    options = (_DAMPING_OPTION,)

    def objective_function(self, robot: Robot):
        damping = self.damping

        def damped_self_motion(terms: TaskTerms, torque):
            # ‖y + K_D Zᵀq̇‖² = ‖(I − J⁺J)(q̈ + K_D q̇)‖², whatever the basis Z
            rest = null_space_projector(terms) @ (joint_acceleration_of(terms, torque) + damping * terms.joint_velocity)
            return float(rest @ rest)

        return damped_self_motion

    def stack_null_space_function(self, robot: Robot):
        damping = self.damping

        def coordinates(terms, null_space_basis, particular):
            return -damping * np.einsum("bji,bj->bi", null_space_basis, terms.joint_velocity)  # y = −K_D Zᵀq̇

        return coordinates

    def null_space_function(self, robot: Robot) -> NullSpaceFunction | None:
        damping = self.damping

        def coordinates(terms: TaskTerms, null_space_basis, particular):
            return -damping * null_space_basis.T.dot(terms.joint_velocity)

        return coordinates


@register_resolver
class DampedNullSpaceTorque(NullSpaceResolver):
    r"""Torque optimisation blended with self-motion damping: min ‖S(τ − τ_mid)‖² + μ̄²‖y + K_D Zᵀq̇‖².

    Over the null-space coordinates :math:`y` (Eq. (26)), with
    :math:`\tau = \tilde\tau + H Z y` and :math:`\tilde\tau` of Eq. (28), this is
    the least-squares problem

    .. math::

        \min_y \left\| \begin{bmatrix} S H Z \\ \bar\mu I \end{bmatrix} y
        - \begin{bmatrix} S(\tau_{mid} - \tilde\tau) \\ -\bar\mu K_D Z^\top\dot q \end{bmatrix} \right\|^2,
        \qquad \bar\mu = \mu \|S H Z\|_F,

    whose normal equations are
    :math:`(Z^\top H S^\top S H Z + \bar\mu^2 I)\,y = Z^\top H S^\top S(\tau_{mid} - \tilde\tau) - \bar\mu^2 K_D Z^\top\dot q`.
    :math:`\mu = 0` gives Eq. (31) (or Eq. (33) with the range weight) exactly;
    as :math:`\mu \to \infty`, :math:`y \to -K_D Z^\top\dot q` (``self-motion-damping``).
    ``torque_weight``: ``unit`` (S = I), ``range`` (Eq. (33)) or a vector, the
    diagonal of :math:`W = S^\top S` [1/(N·m)²].
    """

    name = "damped-null-space"
    equations = (33,)
    needs_redundancy = True
    options = (
        Option(
            name="kinematic_weight",
            kind="number in [0, 1e6]",
            unit="",
            default=DEFAULT_KINEMATIC_WEIGHT,
            meaning="μ: weight of the kinematic term relative to ‖S H Z‖_F (0: null-space; large: self-motion-damping)",
            convert=number(0.0, maximum=LARGEST_WEIGHT),
        ),
        _DAMPING_OPTION,
        Option(
            name="torque_weight",
            kind="'unit' | 'range' | vector (n)",
            unit="1/(N·m)² for a vector",
            default="unit",
            meaning="W = SᵀS of the torque term: identity, 1/(τ⁺−τ⁻)² (Eq. (33)), or its diagonal",
            convert=choice_or_vector("unit", "range"),
        ),
    )

    def objective_function(self, robot: Robot):
        midpoint = torque_midpoint(robot)
        root = self.weight_root(robot)
        relative_weight, damping = self.kinematic_weight, self.damping

        def blend(terms: TaskTerms, torque):
            projector = null_space_projector(terms)
            weight = relative_weight * np.linalg.norm(root[:, None] * (terms.inertia @ projector))  # μ̄ = μ‖S H Z‖_F
            rest = projector @ (joint_acceleration_of(terms, torque) + damping * terms.joint_velocity)
            torque_term = root * (torque - midpoint)
            return float(torque_term @ torque_term + weight**2 * (rest @ rest))

        return blend

    @property
    def needs_torque_limits(self) -> bool:
        return isinstance(self.torque_weight, str) and self.torque_weight == "range"

    def check(self, robot: Robot) -> None:
        super().check(robot)
        if self.needs_torque_limits and not np.isfinite(robot.torque_upper - robot.torque_lower).any():
            raise NoRedundancy(
                f"resolver '{self.name}' with torque_weight=range weights torques by their range, but robot "
                f"'{robot.name}' has no finite torque limit; give torque limits or torque_weight=unit"
            )
        self.weight_root(robot)

    def weight_root(self, robot: Robot) -> np.ndarray:
        """The diagonal of S (S² = W) [1/(N·m)]: see ``torque_weight_root``."""
        return torque_weight_root(self.torque_weight, robot, self.name)

    def stack_null_space_function(self, robot: Robot):
        midpoint = torque_midpoint(robot)
        root = self.weight_root(robot)
        relative_weight, damping, redundancy = self.kinematic_weight, self.damping, robot.redundancy

        def coordinates(terms, null_space_basis, particular):
            offset = midpoint - np.einsum("bij,bj->bi", terms.inertia, particular) - terms.bias_torque
            weighted = root[None, :, None] * (terms.inertia @ null_space_basis)  # S H Z
            if not relative_weight:
                return least_squares(weighted, root * offset)  # Eq. (33)
            # [SHZ; μ̄I] y ≈ [S(τ_mid − τ̃); −μ̄K_D Zᵀq̇], μ̄ = μ‖SHZ‖_F
            weight = relative_weight * np.sqrt(np.einsum("bij,bij->b", weighted, weighted))
            stacked = np.concatenate([weighted, weight[:, None, None] * np.eye(redundancy)], axis=1)
            kinematic = (-damping * weight)[:, None] * np.einsum("bji,bj->bi", null_space_basis, terms.joint_velocity)
            return least_squares(stacked, np.concatenate([root * offset, kinematic], axis=1))

        return coordinates

    def null_space_function(self, robot: Robot) -> NullSpaceFunction | None:
        midpoint = torque_midpoint(robot)
        root = self.weight_root(robot)
        root_column = root[:, None]
        redundancy = robot.redundancy
        relative_weight, damping = self.kinematic_weight, self.damping
        torque_rows = robot.nv
        if relative_weight == 0.0:
            # Exactly the paper's least squares (Eq. (31), Eq. (33)): no kinematic rows at all.
            least_squares = LeastSquares(torque_rows, redundancy)

            def torque_only(terms: TaskTerms, null_space_basis, particular):
                inertia = terms.inertia
                weighted_inertia_basis = root_column * inertia.dot(null_space_basis)
                torque_offset = midpoint - inertia.dot(particular) - terms.bias_torque  # τ_mid − τ̃, Eq. (28)
                return least_squares(weighted_inertia_basis, root * torque_offset)

            return torque_only

        least_squares = LeastSquares(torque_rows + redundancy, redundancy)
        # One stacked system [SHZ; μ̄I] y ≈ [S(τ_mid − τ̃); −μ̄K_D Zᵀq̇], refilled in place at each step
        # through views made once (the diagonal of the lower block is a strided view).
        matrix = np.zeros((torque_rows + redundancy, redundancy))
        rhs = np.zeros(torque_rows + redundancy)
        torque_block = matrix[:torque_rows]
        torque_entries = torque_block.reshape(-1)
        kinematic_diagonal = matrix[torque_rows:].reshape(-1)[:: redundancy + 1]
        torque_rhs, kinematic_rhs = rhs[:torque_rows], rhs[torque_rows:]
        multiply, sqrt = np.multiply, math.sqrt

        def coordinates(terms: TaskTerms, null_space_basis, particular):
            inertia = terms.inertia
            multiply(root_column, inertia.dot(null_space_basis), out=torque_block)  # S H Z
            multiply(root, midpoint - inertia.dot(particular) - terms.bias_torque, out=torque_rhs)  # S(τ_mid − τ̃)
            weight = relative_weight * sqrt(torque_entries.dot(torque_entries))  # μ̄ = μ ‖S H Z‖_F
            kinematic_diagonal[...] = weight
            multiply(null_space_basis.T.dot(terms.joint_velocity), -weight * damping, out=kinematic_rhs)  # −μ̄ K_D Zᵀq̇
            return least_squares(matrix, rhs)

        return coordinates

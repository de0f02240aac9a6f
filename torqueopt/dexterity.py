r"""Dexterity measures of an arm at a configuration: Section 1.2 of the paper and its sources.

With the task Jacobian :math:`J` (m×n, world-aligned, as the resolvers use
it), the joint-space inertia :math:`H` and the gravity torques :math:`g`, all
from Pinocchio at zero velocity:

``manipulability``
    Yoshikawa's measure, Eq. (6): :math:`w = \sqrt{\det(J J^\top)} =
    \prod_i \sigma_i(J)`, the volume factor of the velocity ellipsoid
    :math:`\{J\dot\theta : \|\dot\theta\| \le 1\}`. [m^m] for a position
    task of revolute joints (per rad^m).
``min_singular_value``
    :math:`\sigma_{min}(J)` (Klein & Blaho): the smallest tip speed a unit
    joint speed can give in the worst direction [m/rad]; zero at a singularity.
``dynamic_manipulability``
    Yoshikawa's dynamic manipulability, Eq. (22), Eq. (23), Eq. (24), Eq. (25): at zero velocity the
    pseudo-torque :math:`\tilde\tau = \tau - g` gives the acceleration
    :math:`\ddot x - \dot J\dot\theta = J H^{-1}\tilde\tau` (Eq. (22)); with each
    torque normalised by the range left after gravity,
    :math:`\hat\tau_i = \tilde\tau_i/(\tau^+_i - |g_i|)`, i.e.
    :math:`W = \mathrm{diag}(1/(\tau^+_i - |g_i|))`, :math:`\tilde H = W H`,
    it is :math:`J\tilde H^{-1}\hat\tau` (Eq. (23)), the unit ball
    :math:`\|\hat\tau\| \le 1` maps to the ellipsoid of Eq. (24), and the index is
    :math:`w_d = \sqrt{\det(J(\tilde H^\top\tilde H)^{-1}J^\top)}`, Eq. (25)
    [(m/s²)^m]. The ellipsoid returned is the exact image
    :math:`\{J\tilde H^{-1}\hat\tau : \|\hat\tau\| \le 1\}`, i.e.
    :math:`\ddot x^\top (J\tilde H^{-1}\tilde H^{-\top}J^\top)^{-1}\ddot x \le 1`,
    whose volume factor is Eq. (25). The printed form of Eq. (24),
    :math:`\ddot x^\top(\tilde HJ^\dagger)^\top\tilde HJ^\dagger\ddot x \le 1`,
    describes the same set only when m = n: for a redundant arm
    :math:`\tilde H J^\dagger\ddot x` is one torque that gives
    :math:`\ddot x`, not the smallest.
``khatib_manipulability``
    The same index, Eq. (25), with Khatib's normalisation, as the paper states it
    after Eq. (25): :math:`\hat\tau_i = \min(|\tau^-_i - g_i|, |\tau^+_i - g_i|)`,
    :math:`W = \mathrm{diag}(1/\hat\tau_i)`: the torque that is available in
    both directions after gravity. For symmetric limits
    (:math:`\tau^- = -\tau^+`) this equals :math:`\tau^+_i - |g_i|`, so the
    two normalisations differ only for asymmetric limits.
``khatib_isotropy``
    :math:`\sigma_{min}/\sigma_{max}` of :math:`J\tilde H^{-1}` with Khatib's
    W, in [0, 1]: 1 where the tip can accelerate equally in every direction,
    the isotropy of endpoint acceleration that Khatib (1985) optimised.
``operational_space_manipulability``
    :math:`\sqrt{\det(J H^{-1} J^\top)} = \det(\Lambda)^{-1/2}`, with
    :math:`\Lambda = (J H^{-1}J^\top)^{-1}` Khatib's operational-space
    (pseudo-kinetic-energy) inertia: the volume factor of the accelerations a
    unit-norm *force* at the tip produces, :math:`\ddot x = \Lambda^{-1} F`,
    without torque limits. [(1/kg)^m for a position task.]

A joint whose limit does not even hold gravity (:math:`\tau^+_i \le |g_i|`)
contributes nothing to the normalised ellipsoids (its range is taken as 0);
a joint without a torque limit makes the torque-normalised measures NaN.

:func:`dexterity` evaluates one configuration; :func:`dexterity_along`
evaluates every row of a run (after the run, from its stored
configurations, so the simulation loop is untouched).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from .checks import configuration_vector
from .linalg import inverse_condition_number_of
from .robot import Robot

__all__ = ["DEXTERITY_COLUMNS", "Dexterity", "Ellipsoid", "dexterity", "dexterity_along"]

#: The per-step measures a run records, in this order (columns of the CSV and keys of ``SimResult.dexterity``).
DEXTERITY_COLUMNS = (
    "manipulability",
    "min_singular_value",
    "dynamic_manipulability",
    "khatib_manipulability",
    "khatib_isotropy",
    "operational_space_manipulability",
)
_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


@dataclass(frozen=True)
class Ellipsoid:
    r"""An ellipsoid :math:`\{A u : \|u\| \le 1\}` centred at the tip, in the task's position coordinates.

    Attributes:
        radii: semi-axis lengths, largest first, shape (k,) (k = 2 for the xy task, 3 otherwise).
        axes: unit semi-axis directions as columns, (k×k), world axes.
    """

    radii: np.ndarray
    axes: np.ndarray

    @property
    def semi_axes(self) -> np.ndarray:
        """Semi-axes as columns, each scaled by its radius (k×k)."""
        return self.axes * self.radii

    def outline(self, points: int = 73) -> np.ndarray:
        """``points`` points round the ellipse of the first two axes, relative to the centre, (points × k)."""
        angle = np.linspace(0.0, 2.0 * np.pi, points)
        circle = np.stack([np.cos(angle), np.sin(angle)], axis=1)
        return circle @ self.semi_axes[:, :2].T


@dataclass(frozen=True)
class Dexterity:
    """Dexterity of an arm at one configuration (see the module docstring for the formulas and units).

    Attributes:
        manipulability: w of Eq. (6).
        min_singular_value: σ_min(J) (Klein).
        singular_values: σ(J), largest first, (m,).
        dynamic_manipulability: Eq. (25) with Yoshikawa's W = ``diag(1/(τ⁺ᵢ − |gᵢ|))``.
        khatib_manipulability: Eq. (25) with Khatib's W = ``diag(1/min(|τ⁻ᵢ − gᵢ|, |τ⁺ᵢ − gᵢ|))``.
        khatib_isotropy: σ_min/σ_max of J H̃⁻¹ with Khatib's W.
        operational_space_manipulability: sqrt(det(J H⁻¹ Jᵀ)) = det(Λ)^(−1/2).
        gravity_torque: g at this configuration [N·m], (n,).
        torque_range: ``τ⁺ − |g|``, clipped at 0 [N·m], Yoshikawa's normalisation (n,).
        khatib_torque_range: ``min(|τ⁻ − g|, |τ⁺ − g|)`` [N·m] (n,), 0 where gravity exceeds a limit.
        velocity_ellipsoid: {J q̇ : ‖q̇‖ ≤ 1} over the position rows [m/s per rad/s].
        acceleration_ellipsoid: Eq. (24), {J H̃⁻¹ τ̂ : ‖τ̂‖ ≤ 1} with Yoshikawa's W, position rows [m/s²];
            None when a joint has no torque limit.
    """

    manipulability: float
    min_singular_value: float
    singular_values: np.ndarray
    dynamic_manipulability: float
    khatib_manipulability: float
    khatib_isotropy: float
    operational_space_manipulability: float
    gravity_torque: np.ndarray
    torque_range: np.ndarray
    khatib_torque_range: np.ndarray
    velocity_ellipsoid: Ellipsoid
    acceleration_ellipsoid: Ellipsoid | None

    def measures(self) -> dict[str, float]:
        """The scalar measures, keyed as :data:`~torqueopt.dexterity.DEXTERITY_COLUMNS`."""
        return {name: getattr(self, name) for name in DEXTERITY_COLUMNS}


def dexterity(robot: Robot, q) -> Dexterity:
    """The dexterity measures of ``robot``'s task at configuration ``q`` (at zero velocity).

    Args:
        robot: from :func:`torqueopt.load_robot`; its task, task frame,
            gravity and torque limits are used.
        q: a configuration vector (nq) or one angle per joint (n) [rad].
    """
    jacobian, inertia, gravity = _terms_function(robot)(configuration_vector(robot, q, "q"))
    measures, singular_values, torque_range, khatib_range, yoshikawa = _measures(
        jacobian[None], inertia[None], gravity[None], robot.torque_upper, robot.torque_lower
    )
    linear = slice(0, min(robot.m, 3))
    bounded = np.isfinite(measures["dynamic_manipulability"][0])
    return Dexterity(
        **{name: float(values[0]) for name, values in measures.items()},
        singular_values=singular_values[0],
        gravity_torque=gravity,
        torque_range=torque_range[0],
        khatib_torque_range=khatib_range[0],
        velocity_ellipsoid=_ellipsoid(jacobian[linear]),
        acceleration_ellipsoid=_ellipsoid(yoshikawa[0, linear]) if bounded else None,
    )


def dexterity_along(robot: Robot, q) -> dict[str, np.ndarray]:
    """The measures of :data:`~torqueopt.dexterity.DEXTERITY_COLUMNS` at every row of ``q`` (configuration vectors, N×nq).

    Pass ``result.q`` of a run simulated with ``robot``; the result is what
    ``simulate(..., dexterity=True)`` stores as ``SimResult.dexterity``. Rows
    that are not finite give NaN. Pinocchio evaluates J, H and g row by row;
    the linear algebra runs batched over all rows at once.
    """
    configurations = np.asarray(q, dtype=float).reshape(-1, robot.nq)
    finite = np.isfinite(configurations).all(axis=1)
    columns = {name: np.full(len(configurations), np.nan) for name in DEXTERITY_COLUMNS}
    if not finite.any():
        return columns
    terms = _terms_function(robot)
    jacobians, inertias, gravities = (np.array(stack) for stack in zip(*map(terms, configurations[finite])))
    measures = _measures(jacobians, inertias, gravities, robot.torque_upper, robot.torque_lower)[0]
    for name in DEXTERITY_COLUMNS:
        columns[name][finite] = measures[name]
    return columns


def _terms_function(robot: Robot):
    """A function q -> (J (m×n), H (n×n), g (n)) at zero velocity, from Pinocchio, with its own data."""
    model = robot.model
    data = model.createData()
    frame_id, rows = robot.frame_id, robot.task_rows

    def terms(q: np.ndarray):
        inertia = pin.crba(model, data, q)
        inertia = np.triu(inertia) + np.triu(inertia, 1).T  # CRBA fills the upper triangle
        gravity = pin.computeGeneralizedGravity(model, data, q).copy()
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        return pin.getFrameJacobian(model, data, frame_id, _LWA)[rows].copy(), inertia, gravity

    return terms


def _measures(jacobian, inertia, gravity, upper, lower):
    """The scalar measures for stacks of J (N×m×n), H (N×n×n) and g (N×n), batched over N.

    Returns:
        (measures keyed as DEXTERITY_COLUMNS, σ(J) (N×m), τ⁺ − |g| (N×n),
        Khatib's range (N×n), J H̃⁻¹ with Yoshikawa's W (N×m×n)).
    """
    upper, lower = np.asarray(upper, float), np.asarray(lower, float)
    singular_values = np.linalg.svd(jacobian, compute_uv=False)
    manipulability = np.prod(singular_values, axis=-1)  # Eq. (6): sqrt(det(J Jᵀ)) = Π σᵢ(J)
    # J H⁻¹ (H is symmetric): the map from pseudo-torque to pseudo-acceleration of Eq. (22).
    mobility = np.swapaxes(np.linalg.solve(inertia, np.swapaxes(jacobian, -1, -2)), -1, -2)
    operational = np.sqrt(np.clip(np.linalg.det(mobility @ np.swapaxes(jacobian, -1, -2)), 0.0, None))
    torque_range = np.clip(upper - np.abs(gravity), 0.0, None)  # 1/Wᵢ = τ⁺ᵢ − |gᵢ|, before Eq. (23)
    khatib_range = np.minimum(np.abs(lower - gravity), np.abs(upper - gravity))
    khatib_range = np.where((upper > gravity) & (lower < gravity), khatib_range, 0.0)
    # J H̃⁻¹ = J H⁻¹ W⁻¹ with H̃ = W H, Eq. (23): the image of the unit ball ‖τ̂‖ ≤ 1 is the
    # ellipsoid of Eq. (24), and Π σᵢ(J H̃⁻¹) = sqrt(det(J (H̃ᵀH̃)⁻¹ Jᵀ)) is Eq. (25).
    with np.errstate(invalid="ignore"):  # 0 · inf for a joint without a limit: NaN, and unused below
        yoshikawa = mobility * torque_range[..., None, :]
        khatib = mobility * khatib_range[..., None, :]
    bounded = bool(np.isfinite(upper).all() and np.isfinite(lower).all())
    if bounded:
        with np.errstate(over="ignore"):  # limits near the largest float: the volume is inf, said as such
            dynamic = np.prod(np.linalg.svd(yoshikawa, compute_uv=False), axis=-1)  # Eq. (25)
            khatib_values = np.linalg.svd(khatib, compute_uv=False)
            khatib_manipulability = np.prod(khatib_values, axis=-1)  # Eq. (25) with Khatib's W
        isotropy = inverse_condition_number_of(khatib_values)
    else:
        dynamic = khatib_manipulability = isotropy = np.full(len(jacobian), np.nan)
    measures = {
        "manipulability": manipulability,
        "min_singular_value": singular_values[..., -1],
        "dynamic_manipulability": dynamic,
        "khatib_manipulability": khatib_manipulability,
        "khatib_isotropy": isotropy,
        "operational_space_manipulability": operational,
    }
    return measures, singular_values, torque_range, khatib_range, yoshikawa


def _ellipsoid(mapping: np.ndarray) -> Ellipsoid:
    """The image of the unit ball under ``mapping`` (k×n): left singular vectors scaled by the singular values."""
    left, values, _ = np.linalg.svd(mapping, full_matrices=False)
    return Ellipsoid(radii=values, axes=left)


def summarise_along(t, measures: dict[str, np.ndarray]) -> list[str]:
    """Lines for a run's report: each headline measure at the start and at its lowest, with when [s]."""
    t = np.asarray(t, dtype=float)
    labels = {
        "manipulability": "manipulability w, Eq. (6)",
        "min_singular_value": "smallest singular value of J",
        "dynamic_manipulability": "dynamic manipulability, Eq. (25)",
    }
    lines = []
    for name, label in labels.items():
        values = np.asarray(measures.get(name, ()), dtype=float)
        finite = np.flatnonzero(np.isfinite(values))
        if not finite.size:
            if name == "dynamic_manipulability" and values.size:
                lines.append(f"{label}: none (a joint has no torque limit)")
            continue
        lowest = finite[np.argmin(values[finite])]
        lines.append(
            f"{label}: {values[finite[0]]:.4g} at the start, lowest {values[lowest]:.4g} at t = {t[lowest]:.3f} s"
        )
    return lines

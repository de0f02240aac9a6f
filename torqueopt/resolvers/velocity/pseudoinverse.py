r"""Resolved rate with the pseudoinverse and with the kinetic-energy-weighted pseudoinverse."""

from __future__ import annotations

import eigenpy
import numpy as np
import pinocchio as pin

from ...checks import finite_numbers
from ...linalg import InverseCondition, PseudoInverse, inverse_condition_number_of
from ...robot import Robot
from ...tasks import FrameTask, Kinematics, PerConfiguration
from ..options import Option
from ..registry import register_resolver
from ..stacks import singular_rows
from .base import POSITION_GAIN_OPTION, VelocityResolver, VelocityStack, pseudoinverse_solver
from .options import vector_or_callable

__all__ = ["VelocityPseudoInverse", "KineticEnergyPseudoInverse"]


@register_resolver
class VelocityPseudoInverse(VelocityResolver):
    r"""Resolved rate (Whitney) with the Moore-Penrose pseudoinverse, Eq. (1), Eq. (2), Eq. (3).

    .. math::

        \dot q = J^\dagger \dot x + (I - J^\dagger J)\dot\phi \quad\text{Eq. (2)},\qquad
        J^\dagger = J^\top (J J^\top)^{-1} \quad\text{Eq. (3)}

    With :math:`\dot\phi = 0` (the default) the joint rates minimise
    :math:`\dot q^\top \dot q` among those realising :math:`\dot x = J\dot q`
    Eq. (1). The null-space projection :math:`I - J^\dagger J = ZZ^\top` is
    applied through an orthonormal basis Z of the null space of J.

    Args:
        self_motion: :math:`\dot\phi` [rad/s]: n values, or a callable
            ``phi(joint_angles) -> n values``; zero by default.
    """

    name = "velocity-pinv"
    equations = (1, 2, 3)
    options = (
        Option(
            name="self_motion",
            kind="vector (n values) | callable phi(joint_angles)",
            unit="rad/s",
            default=None,
            meaning="the arbitrary joint velocity φ̇ of Eq. (2), projected into the null space of J",
            convert=vector_or_callable,
            default_text="none (φ̇ = 0)",
        ),
        POSITION_GAIN_OPTION,
    )

    def check(self, robot: Robot) -> None:
        super().check(robot)
        if isinstance(self.self_motion, np.ndarray):
            finite_numbers(self.self_motion, "self_motion", robot.nv, unit="rad/s", context="(one rate per joint)")

    def rate_function(self, robot: Robot, task: FrameTask):
        decompose = pseudoinverse_solver(robot, self.singular_tolerance, null_space=self.self_motion is not None)
        self_motion = self.self_motion

        def rates(kinematics: Kinematics, task_velocity: np.ndarray):
            # Eq. (3) by SVD: J⁺ẋ (the least-norm q̇ of Eq. (1)), the null-space basis Z, and σmin/σmax
            particular, basis, inverse_condition = decompose(task.jacobian(kinematics), task_velocity)
            if self_motion is None or basis is None:
                return particular, inverse_condition  # Eq. (2) with φ̇ = 0
            phi = self_motion(robot.joint_angles(kinematics.q)) if callable(self_motion) else self_motion
            return particular + basis.dot(basis.T.dot(phi)), inverse_condition  # Eq. (2): (I − J⁺J)φ̇ = Z Zᵀφ̇

        return rates

    def acceleration_function(self, robot: Robot, task: FrameTask):
        r"""q̈ of :math:`\dot q = J^\dagger c` in closed form, for φ̇ = 0 on a position task (else None).

        With :math:`G = JJ^\top` and :math:`w = G^{-1}c` (so :math:`\dot q = J^\top w`),
        differentiating Eq. (3) for a J of full row rank,

        .. math::

            \ddot q = J^\dagger(\dot c - \dot J\dot q) + (I - J^\dagger J)\dot J^\top w,

        from :math:`\frac{d}{dt}J^\dagger = \dot J^\top G^{-1} - J^\top G^{-1}(\dot J J^\top + J\dot J^\top)G^{-1}`;
        :math:`\dot J` from Pinocchio's Jacobian time variation at (q, q̇).
        """
        if self.self_motion is not None or task.kind == "pose":
            return None

        pseudoinverse_of = PseudoInverse(robot.m, robot.nv)

        def acceleration(kinematics: Kinematics, velocity: np.ndarray, command: np.ndarray, command_rate: np.ndarray):
            jacobian = task.jacobian(kinematics)
            jacobian_rate = task.jacobian_rate(kinematics, velocity)
            pseudoinverse = pseudoinverse_of(jacobian)  # Eq. (3)
            # w = G⁻¹c = J⁺ᵀJ⁺c = J⁺ᵀq̇, so the second term is (I − J⁺J)J̇ᵀJ⁺ᵀq̇
            rate_of_rates = jacobian_rate.T.dot(pseudoinverse.T.dot(velocity))
            return pseudoinverse.dot(command_rate - jacobian_rate.dot(velocity)) + (
                rate_of_rates - pseudoinverse.dot(jacobian.dot(rate_of_rates))
            )

        return acceleration

    def stack_rate_function(self, robot: Robot):
        """Eq. (3) and the closed-form q̈ of :meth:`acceleration_function` on stacks (φ̇ = 0 on a position task)."""
        if self.self_motion is not None or robot.task == "pose":
            return None
        return StackedPseudoInverse(self.singular_tolerance)


class StackedPseudoInverse(VelocityStack):
    r""":math:`\dot q = J^\dagger c` and its :math:`\ddot q` per row of (B, m, n) stacks, :math:`J^\dagger = J^\top(JJ^\top)^{-1}`."""

    def __init__(self, tolerance: float):
        self.tolerance = tolerance

    def rates(
        self, jacobian: np.ndarray, command: np.ndarray, configuration: np.ndarray | None = None, kinematics=None
    ):
        """(q̇ (B, n), σmin/σmax (B,), failures, J⁺ (B, n, m)); a singular row gets a finite, unused answer.

        J⁺c depends on q only through J: ``configuration`` and ``kinematics`` are not read."""
        jacobian_t = np.swapaxes(jacobian, 1, 2)
        gram = jacobian @ jacobian_t
        conditions, failures, determinant = self.conditions(gram)
        pseudoinverse = jacobian_t @ stacked_inverse(gram, failures, determinant)  # Eq. (3)
        return np.einsum("bij,bj->bi", pseudoinverse, command), conditions, failures, pseudoinverse

    def conditions(self, gram: np.ndarray):
        r"""σmin/σmax of J per row from :math:`G = JJ^\top` (B, m, m), the singular rows, and det G for two rows.

        σ² of J are the eigenvalues of G (relative error ε/(σmin/σmax)², far below what the cutoff decides).
        For two rows, with :math:`G = \begin{pmatrix} a & b\\ b & d\end{pmatrix}`, in closed form on the batch
        axis: :math:`\lambda_{max} = \tfrac{a+d}2 + \sqrt{(\tfrac{a-d}2)^2 + b^2}`,
        :math:`\lambda_{min} = \det G/\lambda_{max}` (no cancellation beyond that of :math:`\det G = ad - b^2`, the
        same relative error as the eigenvalues by LAPACK); more rows by LAPACK (det G is then None).
        """
        if gram.shape[1] == 2:
            a, b, d = gram[:, 0, 0], gram[:, 0, 1], gram[:, 1, 1]
            half_difference = 0.5 * (a - d)
            largest = 0.5 * (a + d) + np.sqrt(half_difference * half_difference + b * b)
            determinant = a * d - b * b
            safe = np.where(largest > 0.0, largest, 1.0)
            conditions = np.where(largest > 0.0, np.sqrt(np.maximum(determinant / safe, 0.0) / safe), 0.0)
        else:
            squared = np.linalg.eigvalsh(gram)
            conditions = inverse_condition_number_of(np.sqrt(np.maximum(squared[:, ::-1], 0.0)))
            determinant = None
        return conditions, singular_rows(conditions, self.tolerance), determinant

    @staticmethod
    def acceleration(jacobian, jacobian_rate, velocity, command_rate, pseudoinverse, kinematics=None) -> np.ndarray:
        """J⁺(ċ − J̇q̇) + (I − J⁺J)J̇ᵀJ⁺ᵀq̇ per row (see :meth:`VelocityPseudoInverse.acceleration_function`)."""
        rate_of_rates = np.einsum("bji,bj->bi", jacobian_rate, np.einsum("bji,bj->bi", pseudoinverse, velocity))
        residual = command_rate - np.einsum("bij,bj->bi", jacobian_rate, velocity)
        return np.einsum("bij,bj->bi", pseudoinverse, residual) + (
            rate_of_rates - np.einsum("bij,bj->bi", pseudoinverse, np.einsum("bij,bj->bi", jacobian, rate_of_rates))
        )


@register_resolver
class KineticEnergyPseudoInverse(VelocityResolver):
    r"""Weighted pseudoinverse with :math:`W = H`: minimum kinetic energy, Eq. (16), Eq. (17).

    .. math::

        \dot q = J_H^\dagger \dot x,\qquad
        J_W^\dagger = W^{-1} J^\top (J W^{-1} J^\top)^{-1} \quad\text{Eq. (16)}

    which minimises :math:`T = \tfrac12 \dot q^\top H \dot q` (Eq. (17), [J])
    among the joint rates with :math:`J\dot q = \dot x` (Whitney). :math:`H^{-1}`
    is Pinocchio's (``computeMinverse``, by the articulated-body recursion) at q.
    This is the velocity-level twin of the acceleration-level ``inertia-pinv`` Eq. (19).
    """

    name = "kinetic-energy-pinv"
    equations = (16, 17)

    def rate_function(self, robot: Robot, task: FrameTask):
        return self.step_functions(robot, task)[0]

    def acceleration_function(self, robot: Robot, task: FrameTask):
        r"""q̈ of :math:`\dot q = J_H^\dagger c` in closed form, on a position task (None for ``pose``).

        With :math:`A = H^{-1}J^\top`, :math:`G = JA` and the multipliers :math:`\lambda = G^{-1}c`
        (so :math:`\dot q = A\lambda`, :math:`J_H^\dagger = AG^{-1}`, Eq. (16) with W = H),
        differentiating along the motion (:math:`\dot A = H^{-1}(\dot J^\top - \dot H A)`,
        :math:`\dot G = \dot J A + J\dot A`):

        .. math::

            \ddot q = J_H^\dagger(\dot c - \dot J\dot q) + (I - J_H^\dagger J)\,H^{-1}(\dot J^\top\lambda - \dot H\dot q),

        which for H = I is velocity-pinv's. :math:`\dot J` from Pinocchio's Jacobian time variation at
        (q, q̇), :math:`H^{-1}` from ``computeMinverse`` and :math:`\dot H = C + C^\top` from its Coriolis matrix
        (``computeCoriolisMatrix``, for which :math:`\dot H - 2C` is skew). J, :math:`H^{-1}`, A and the
        factors of G at q are those the rates computed there, when they did.
        """
        return self.step_functions(robot, task)[1]

    def step_functions(self, robot: Robot, task: FrameTask):
        """Eq. (16)'s rates with W = H and their closed-form q̈ (None for ``pose``), sharing J, H⁻¹, A and G's
        Cholesky factors at each configuration.

        The factors live in one decomposition object for the run, refactored at each configuration: a value that
        :class:`~torqueopt.tasks.PerConfiguration` still holds is the configuration the object was last given."""
        condition_of = InverseCondition(robot.m, robot.nv, self.singular_tolerance)
        gram = eigenpy.LLT(robot.m)

        @PerConfiguration
        def at_configuration(kinematics: Kinematics):
            jacobian = task.jacobian(kinematics)
            inverse_condition = condition_of(jacobian)  # raises SingularJacobian when J loses rank
            inverse_inertia = inverse_inertia_at(kinematics)
            weighted_jt = inverse_inertia.dot(jacobian.T)  # A = W⁻¹Jᵀ with W = H
            gram.compute(jacobian.dot(weighted_jt))  # G = JH⁻¹Jᵀ of Eq. (16), its Cholesky factors
            return jacobian, inverse_inertia, weighted_jt, inverse_condition

        def rates(kinematics: Kinematics, task_velocity: np.ndarray):
            _, _, weighted_jt, inverse_condition = at_configuration(kinematics)
            # Eq. (16) with W = H: H⁻¹Jᵀ(JH⁻¹Jᵀ)⁻¹ẋ, the q̇ of least kinetic energy Eq. (17)
            return weighted_jt.dot(gram.solve(task_velocity)), inverse_condition

        def acceleration(kinematics: Kinematics, velocity: np.ndarray, command: np.ndarray, command_rate: np.ndarray):
            jacobian, inverse_inertia, weighted_jt, _ = at_configuration(kinematics)
            coriolis = pin.computeCoriolisMatrix(kinematics.model, kinematics.data, kinematics.q, velocity)
            inertia_rate_velocity = coriolis.dot(velocity) + velocity.dot(coriolis)  # Ḣq̇ = (C + Cᵀ)q̇
            jacobian_rate = task.jacobian_rate(kinematics, velocity)
            multipliers = gram.solve(command)  # λ = G⁻¹c, q̇ = Aλ
            # the weighted pseudoinverse's own rate acts through H⁻¹(J̇ᵀλ − Ḣq̇), projected by I − J_H⁺J
            inner = inverse_inertia.dot(multipliers.dot(jacobian_rate) - inertia_rate_velocity)
            residual = command_rate - jacobian_rate.dot(velocity) - jacobian.dot(inner)
            # the time derivative of Eq. (16) with W = H applied to c
            return inner + weighted_jt.dot(gram.solve(residual))

        return rates, None if task.kind == "pose" else acceleration

    def stack_rate_function(self, robot: Robot):
        """Eq. (16) with W = H and the closed-form q̈ of :meth:`acceleration_function` on stacks (position tasks)."""
        if robot.task == "pose":
            return None
        return StackedKineticEnergyPseudoInverse(self.singular_tolerance)


class StackedKineticEnergyPseudoInverse(StackedPseudoInverse):
    r""":math:`\dot q = H^{-1}J^\top(JH^{-1}J^\top)^{-1}c` (Eq. (16) with W = H) and its :math:`\ddot q` per row of
    (B, m, n) stacks; H at each configuration and :math:`\dot H\dot q` at the step's start are those the batch's
    forest computes with J and :math:`\dot J` in the same pass
    (:meth:`RobotForest.kinematics <torqueopt.robot_copies.RobotForest.kinematics>`, ``inertia``,
    ``inertia_rate``), :math:`H^{-1}` the inverse of each row's H (``symmetric_inverses_rows_last``: its cofactors
    for three joints; CRBA's pass costs less than ``computeMinverse``'s on the forest, whose H⁻¹ is computed whole);
    σmin/σmax of J and the singular rows as :class:`StackedPseudoInverse` finds them. What :meth:`rates` keeps for
    :meth:`acceleration` and :meth:`energies` is held with the batch axis last."""

    reads_inertia = True
    reads_inertia_rate = True
    #: CRBA's and the Coriolis matrix's bindings clear, symmetrise and return the forest's whole (n, n) matrices,
    #: a cost that grows with the square of a pass's joints; fewer copies per pass make more passes. On planar3
    #: 8 copies (24 joints) counted fewest instructions per trajectory-step (BENCHMARKS.md).
    forest_dofs = 24

    def rates(self, jacobian: np.ndarray, command: np.ndarray, configuration: np.ndarray, kinematics=None):
        """(q̇, σmin/σmax, failures, what :meth:`acceleration` reuses); a singular row gets a finite, unused answer.
        ``kinematics``: the forest's at ``configuration``, with H.

        Held component-first, the batch axis last (J (m, n, B), H⁻¹ (n, n, B), ...): each small product is one
        ``np.einsum`` over the batch, where numpy's product of (B, ·, ·) stacks calls BLAS once per row."""
        task = np.ascontiguousarray(np.moveaxis(jacobian, 0, 2))  # J, (m, n, B)
        conditions, failures, _ = self.conditions(np.moveaxis(np.einsum("ijb,kjb->ikb", task, task), 2, 0))
        inverse_inertia = symmetric_inverses_rows_last(kinematics.inertia)  # H⁻¹, (n, n, B)
        weighted_jt = np.einsum("ijb,kjb->ikb", inverse_inertia, task)  # A = H⁻¹Jᵀ, (n, m, B)
        gram = np.einsum("ijb,jkb->ikb", task, weighted_jt)  # G = JH⁻¹Jᵀ of Eq. (16), (m, m, B)
        gram_inverse = np.moveaxis(stacked_inverse(np.moveaxis(gram, 2, 0), failures), 0, 2)  # G⁻¹
        multipliers = np.einsum("ijb,bj->ib", gram_inverse, command)  # λ = G⁻¹c, (m, B)
        # Eq. (16) with W = H: q̇ = Aλ, the least kinetic energy Eq. (17)
        velocity = np.einsum("ijb,jb->bi", weighted_jt, multipliers)
        return velocity, conditions, failures, (task, inverse_inertia, weighted_jt, gram_inverse, multipliers)

    def acceleration(self, jacobian, jacobian_rate, velocity, command_rate, state, kinematics=None) -> np.ndarray:
        """r + AG⁻¹(ċ − J̇q̇ − Jr), r = H⁻¹(J̇ᵀλ − Ḣq̇), per row (see :meth:`KineticEnergyPseudoInverse.acceleration_function`).
        ``kinematics``: the forest's at the configuration and q̇, with Ḣq̇."""
        task, inverse_inertia, weighted_jt, gram_inverse, multipliers = state
        rate = np.ascontiguousarray(np.moveaxis(jacobian_rate, 0, 2))  # J̇, (m, n, B)
        inertia_rate_velocity = kinematics.inertia_rate_velocity.T  # Ḣq̇ = (C + Cᵀ)q̇, (n, B)
        inner = np.einsum(
            "ijb,jb->ib", inverse_inertia, np.einsum("jib,jb->ib", rate, multipliers) - inertia_rate_velocity
        )
        residual = command_rate.T - np.einsum("ijb,bj->ib", rate, velocity) - np.einsum("ijb,jb->ib", task, inner)
        # the time derivative of Eq. (16) with W = H applied to c
        return (inner + np.einsum("ijb,jb->ib", weighted_jt, np.einsum("ijb,jb->ib", gram_inverse, residual))).T.copy()

    def energies(self, jacobian, velocity, state, kinematics):
        r"""T and E_N per row (see :meth:`VelocityStack.energies`) from the pass's H and the G⁻¹ of :meth:`rates`:
        :math:`T = \tfrac12\dot q^\top H\dot q`, :math:`E_N = T - \tfrac12\dot x^\top G^{-1}\dot x` with
        :math:`G = JH^{-1}J^\top`, the task-space inertia's inverse, kept at or above 0 against round-off (for
        this method's own q̇, Eq. (16) with W = H, :math:`E_N` is 0 but for round-off)."""
        task, gram_inverse = state[0], state[3]
        kinetic = 0.5 * np.einsum("bi,bij,bj->b", velocity, kinematics.inertia, velocity)
        tip_velocity = np.einsum("ijb,bj->ib", task, velocity)  # ẋ = Jq̇, (m, B)
        task_energy = 0.5 * np.einsum("ib,ijb,jb->b", tip_velocity, gram_inverse, tip_velocity)  # ½ẋᵀΛẋ, Λ = G⁻¹
        return kinetic, np.maximum(kinetic - task_energy, 0.0)


def stacked_inverse(gram: np.ndarray, failures: dict, determinant: np.ndarray | None = None) -> np.ndarray:
    """The inverse of each (m, m) matrix of a (B, m, m) stack, the rows in ``failures`` given the identity's (a
    finite, unused answer); ``gram`` is overwritten.

    For m = 2 in closed form on the batch axis, G⁻¹ = ((d, −b), (−c, a)) / (ad − bc), no LAPACK call per row
    (``determinant``: ad − bc when the caller has it); else by LAPACK.
    """
    if gram.shape[1] != 2:
        if failures:
            gram[list(failures)] = np.eye(gram.shape[1])
        return np.linalg.inv(gram)
    if determinant is None:
        determinant = gram[:, 0, 0] * gram[:, 1, 1] - gram[:, 0, 1] * gram[:, 1, 0]
    inverse = np.empty_like(gram)
    inverse[:, 0, 0], inverse[:, 1, 1] = gram[:, 1, 1], gram[:, 0, 0]
    inverse[:, 0, 1], inverse[:, 1, 0] = -gram[:, 0, 1], -gram[:, 1, 0]
    if failures:
        rows = list(failures)
        inverse[rows], determinant[rows] = np.eye(2), 1.0
    return inverse / determinant[:, None, None]


def stacked_symmetric_inverse(matrices: np.ndarray) -> np.ndarray:
    """The inverse of each symmetric, invertible (n, n) matrix of a (B, n, n) stack (a fresh stack, laid out as
    :func:`symmetric_inverses_rows_last` computes it)."""
    return symmetric_inverses_rows_last(matrices).transpose(2, 0, 1)


def symmetric_inverses_rows_last(matrices: np.ndarray) -> np.ndarray:
    """The inverse of each symmetric, invertible (n, n) matrix of a (B, n, n) stack, as an (n, n, B) array, the batch
    axis last: for n = 3 by its cofactors on the batch axis (the adjugate over the determinant), no LAPACK call per
    row; else by LAPACK."""
    if matrices.shape[1] != 3:
        return np.linalg.inv(matrices).transpose(1, 2, 0)
    a, b, c = matrices[:, 0, 0], matrices[:, 0, 1], matrices[:, 0, 2]
    d, e, f = matrices[:, 1, 1], matrices[:, 1, 2], matrices[:, 2, 2]
    inverse = np.empty((3, 3, matrices.shape[0]))
    inverse[0, 0] = d * f - e * e
    inverse[0, 1] = inverse[1, 0] = c * e - b * f
    inverse[0, 2] = inverse[2, 0] = b * e - c * d
    inverse[1, 1] = a * f - c * c
    inverse[1, 2] = inverse[2, 1] = b * c - a * e
    inverse[2, 2] = a * d - b * b
    determinant = a * inverse[0, 0] + b * inverse[0, 1] + c * inverse[0, 2]
    inverse /= determinant
    return inverse


def inverse_inertia_at(kinematics: Kinematics) -> np.ndarray:
    r""":math:`H^{-1}(q)` (n×n) at a kinematics' configuration, by Pinocchio's ``computeMinverse``.

    The C++ function fills the upper triangle only; its Python binding copies it into the lower one and
    returns a fresh array (tests/test_kinematic.py holds both).
    """
    return pin.computeMinverse(kinematics.model, kinematics.data, kinematics.q)

"""The one σmin/σmax (torqueopt.linalg) and the self-motion energy (torqueopt.self_motion): against matrices of known
singular values and a direct minimisation, and every path that computes them (the SVD solver, the batch's QR and
closed form, the one-state and the stacked energy) held to them."""

import numpy as np
import pinocchio as pin
import pytest

from torqueopt.linalg import JacobianSolver, inverse_condition_number, inverse_condition_number_of
from torqueopt.resolvers.stacks import complete_qr, two_row_qr
from torqueopt.self_motion import self_motion, self_motion_energy


def known_matrices(rng, count, rows, columns):
    """(U Σ Wᵀ stacks, their σmin/σmax) for random orthonormal U, W and σ from 2 down to 2·10⁻⁷ of it."""
    u = np.linalg.qr(rng.normal(size=(count, rows, rows)))[0]
    w = np.linalg.qr(rng.normal(size=(count, columns, columns)))[0][:, :, :rows]
    ratios = 10.0 ** rng.uniform(-7, 0, count)
    middle = rng.uniform(ratios[:, None], 1.0, (count, rows - 2)) if rows > 2 else np.empty((count, 0))
    sigma = 2.0 * np.column_stack([np.ones(count), middle, ratios])
    return u @ (sigma[:, :, None] * np.swapaxes(w, 1, 2)), ratios


@pytest.mark.parametrize("rows, columns", [(2, 3), (3, 7), (6, 7)])
def test_the_inverse_condition_number_is_the_ratio_of_the_known_singular_values(rows, columns, rng):
    matrices, ratios = known_matrices(rng, 50, rows, columns)
    np.testing.assert_allclose(inverse_condition_number(matrices), ratios, rtol=1e-8)
    for matrix, ratio in zip(matrices[:5], ratios):
        value = inverse_condition_number(matrix)
        assert isinstance(value, float) and value == pytest.approx(ratio, rel=1e-8)
        solver = JacobianSolver(rows, columns, tolerance=0.0)
        assert solver(matrix, np.ones(rows))[2] == pytest.approx(ratio, rel=1e-8)  # the SVD solver's own values
    assert inverse_condition_number(np.zeros((2, 3))) == 0.0
    np.testing.assert_array_equal(inverse_condition_number(np.zeros((4, 2, 3))), 0.0)
    assert inverse_condition_number_of([4.0, 1.0]) == 0.25 and inverse_condition_number_of([0.0, 0.0]) == 0.0


@pytest.mark.parametrize("joints", [2, 3, 7])
def test_the_batch_factorisations_report_the_same_inverse_condition(joints, rng):
    matrices, ratios = known_matrices(rng, 200, 2, joints)
    residual = rng.normal(size=(200, 2))
    # complete_qr takes σ² from JJᵀ: a relative error of about ε/ratio², 2e-4 at the batch's cutoff 1e-6.
    relative_error = np.abs(complete_qr(matrices, residual, joints > 2)[2] / ratios - 1.0)
    assert (relative_error <= 4e-16 / ratios**2 + 1e-12).all()
    if joints <= 3:  # the closed form of the planar arm's two-row task
        np.testing.assert_allclose(two_row_qr(matrices, residual, joints > 2)[2], ratios, rtol=1e-8)


def least_energy(inertia, jacobian, velocity):
    """½ q̇'ᵀHq̇' of the q̇' with Jq̇' = Jq̇ of least kinetic energy, by a KKT solve."""
    n, m = jacobian.shape[1], jacobian.shape[0]
    kkt = np.block([[inertia, jacobian.T], [jacobian, np.zeros((m, m))]])
    least = np.linalg.solve(kkt, np.concatenate([np.zeros(n), jacobian @ velocity]))[:n]
    return 0.5 * least @ inertia @ least


@pytest.mark.parametrize("arm", ["planar3", "panda"])
def test_the_self_motion_energy_by_the_jacobian_and_by_a_null_space_basis_is_a_direct_minimisation(arm, request, rng):
    robot = request.getfixturevalue(arm)
    pin.seed(int(rng.integers(2**31)))
    data = robot.model.createData()
    count = 6
    inertia, jacobian = np.empty((count, robot.nv, robot.nv)), np.empty((count, robot.m, robot.nv))
    velocity = rng.normal(size=(count, robot.nv))
    for row in range(count):
        q = pin.randomConfiguration(robot.model)
        upper = pin.crba(robot.model, data, q)
        inertia[row] = np.triu(upper) + np.triu(upper, 1).T
        jacobian[row] = pin.computeFrameJacobian(robot.model, data, q, robot.frame_id, pin.LOCAL_WORLD_ALIGNED)[
            robot.task_rows
        ]
    basis = np.linalg.svd(jacobian)[2][:, robot.m :, :].transpose(0, 2, 1)  # orthonormal null space of each J
    kinetic, by_jacobian = self_motion_energy(inertia, velocity, jacobian=jacobian)
    kinetic_z, by_basis = self_motion_energy(inertia, velocity, null_space_basis=basis)
    for row in range(count):
        expected_kinetic = 0.5 * velocity[row] @ inertia[row] @ velocity[row]
        expected = expected_kinetic - least_energy(inertia[row], jacobian[row], velocity[row])
        assert kinetic[row] == pytest.approx(expected_kinetic, rel=1e-12)
        assert kinetic_z[row] == pytest.approx(expected_kinetic, rel=1e-12)
        assert by_jacobian[row] == pytest.approx(expected, rel=1e-8, abs=1e-12)
        assert by_basis[row] == pytest.approx(expected, rel=1e-8, abs=1e-12)
        single = self_motion(inertia[row], basis[row], velocity[row])  # the one-state form
        assert (single.kinetic_energy, single.energy) == pytest.approx(
            (kinetic[row], by_basis[row]), rel=1e-12, abs=1e-14
        )
    # Without a null space (no redundancy) there is no self-motion.
    assert not self_motion_energy(inertia, velocity, null_space_basis=None)[1].any()

"""The one σmin/σmax (torqueopt.linalg) and the self-motion energy (torqueopt.self_motion): against matrices of known
singular values and a direct minimisation, and every path that computes them (the SVD solver, the batch's QR and
closed form, the one-state and the stacked energy) held to them."""

import numpy as np
import pinocchio as pin
import pytest

from torqueopt.linalg import (
    InverseCondition,
    JacobianSolver,
    determinants,
    inverse_condition_number,
    inverse_condition_number_of,
)
from torqueopt.resolvers.stacks import (
    complete_qr,
    complete_qr_by_lapack,
    least_squares,
    least_squares_by_svd,
    two_row_qr,
)
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


@pytest.mark.parametrize("rows, columns", [(2, 3), (3, 7), (6, 7), (2, 2)])
def test_the_inverse_condition_without_singular_vectors_is_the_solvers_bit_for_bit(rows, columns, rng):
    """InverseCondition (Eigen's SVD without U and V) against JacobianSolver, whose solves need them; both
    refuse a Jacobian below the cutoff, with the same message."""
    from torqueopt.errors import SingularJacobian

    alone, solver = InverseCondition(rows, columns, 1e-6), JacobianSolver(rows, columns, 1e-6, null_space=False)
    for _ in range(20):
        jacobian = rng.normal(size=(rows, columns)) * rng.uniform(0.01, 10.0)
        assert alone(jacobian) == solver.inverse_condition(jacobian)
        expected = np.linalg.svd(jacobian, compute_uv=False)
        assert alone(jacobian) == pytest.approx(expected[-1] / expected[0], rel=1e-12)
    singular = rng.normal(size=(rows, columns))
    singular[-1] = 2.0 * singular[0]
    with pytest.raises(SingularJacobian) as refused:
        alone(singular)
    with pytest.raises(SingularJacobian) as refused_too:
        solver.inverse_condition(singular)
    assert str(refused.value) == str(refused_too.value)


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


def random_inertias_and_jacobians(robot, count, rng):
    """H (symmetric, by Pinocchio's CRBA) and the task's J at ``count`` random configurations of ``robot``."""
    pin.seed(int(rng.integers(2**31)))
    data = robot.model.createData()
    inertia, jacobian = np.empty((count, robot.nv, robot.nv)), np.empty((count, robot.m, robot.nv))
    for row in range(count):
        q = pin.randomConfiguration(robot.model)
        upper = pin.crba(robot.model, data, q)
        inertia[row] = np.triu(upper) + np.triu(upper, 1).T
        frame_jacobian = pin.computeFrameJacobian(robot.model, data, q, robot.frame_id, pin.LOCAL_WORLD_ALIGNED)
        jacobian[row] = frame_jacobian[robot.task_rows]
    return inertia, jacobian


@pytest.mark.parametrize("arm", ["planar3", "panda"])
def test_the_self_motion_energy_by_the_jacobian_and_by_a_null_space_basis_is_a_direct_minimisation(arm, request, rng):
    robot = request.getfixturevalue(arm)
    count = 6
    inertia, jacobian = random_inertias_and_jacobians(robot, count, rng)
    velocity = rng.normal(size=(count, robot.nv))
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


@pytest.mark.parametrize("rows, columns", [(2, 7), (3, 7), (6, 7), (3, 4), (1, 7)])
def test_the_householder_factorisation_on_the_batch_axis_equals_lapack_row_by_row(rows, columns, rng):
    """complete_qr (Householder reflections on the whole stack) against numpy's QR per row: the same minimum-norm
    solution (to κ·ε), the same null space (projectors ZZᵀ; a basis is unique only up to rotation), J Z = 0,
    ZᵀZ = I, and the same σmin/σmax; with singular rows (σmin/σmax down to 1e-7) among them."""
    matrices, _ = known_matrices(rng, 300, rows, columns) if rows > 1 else (rng.normal(size=(300, 1, columns)), None)
    residual = rng.normal(size=(300, rows))
    particular, basis, conditions = complete_qr(matrices, residual, True)
    reference, reference_basis, reference_conditions = complete_qr_by_lapack(matrices, residual, True)
    ratios = inverse_condition_number(matrices)
    scale = np.linalg.norm(reference, axis=1)
    assert np.all(np.linalg.norm(particular - reference, axis=1) <= 1e-14 * scale / ratios + 1e-14)
    np.testing.assert_array_equal(conditions, reference_conditions)
    assert np.max(np.abs(matrices @ basis)) < 1e-14
    assert np.max(np.abs(np.swapaxes(basis, 1, 2) @ basis - np.eye(columns - rows))) < 1e-14
    well = ratios > 1e-3
    projector = basis @ np.swapaxes(basis, 1, 2)
    reference_projector = reference_basis @ np.swapaxes(reference_basis, 1, 2)
    assert np.max(np.abs(projector - reference_projector)[well]) < 1e-12


@pytest.mark.parametrize("shape", [(200, 7, 4), (200, 10, 4), (200, 3, 2), (200, 3, 5), (200, 7, 1)])
def test_the_householder_least_squares_equals_the_svd_one(shape, rng):
    """least_squares on the batch axis against the SVD reference, with rank-deficient rows (two equal columns, a zero
    column: the minimum-norm answer, which only the SVD path gives) mixed in."""
    matrix = rng.normal(size=shape)
    if shape[2] > 1:
        matrix[:20, :, -1] = matrix[:20, :, 0]
        matrix[20:30, :, 0] = 0.0
    rhs = rng.normal(size=shape[:2])
    np.testing.assert_allclose(least_squares(matrix, rhs), least_squares_by_svd(matrix, rhs), rtol=0, atol=1e-12)
    # and the normal equations at the full-rank rows: Aᵀ(Ay − b) = 0
    y = least_squares(matrix[30:], rhs[30:])
    gradient = np.einsum("bji,bj->bi", matrix[30:], np.einsum("bij,bj->bi", matrix[30:], y) - rhs[30:])
    assert np.max(np.abs(gradient)) < 1e-12


@pytest.mark.parametrize("size", [1, 2, 3, 4])
def test_the_determinants_of_a_stack_are_lapacks(size, rng):
    """The Leibniz formulas for k <= 3 (and LAPACK beyond) against np.linalg.det, one matrix at a time."""
    stack = rng.normal(size=(4, 3, size, size))
    expected = np.array([[np.linalg.det(matrix) for matrix in row] for row in stack])
    np.testing.assert_allclose(determinants(stack), expected, rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("arm", ["panda", "random"])
def test_the_self_motion_energy_by_elimination_is_the_solves(arm, request, rng):
    """self_motion_energy from a basis of two or more columns (one (r+1)×(r+1) matrix eliminated on the batch axis)
    against self_motion_energy_by_solve (Zᵀ H Z solved by LAPACK per row) at 1e-12 of T, on panda's states with the
    batch's own QR basis and on random H, Z of 2 to 5 columns; a row whose Zᵀ H Z is singular (two equal columns) is
    the solve's (through the pseudoinverse), the others stay the elimination's."""
    from torqueopt.self_motion import self_motion_energy_by_solve

    count = 300
    if arm == "panda":
        robot = request.getfixturevalue("panda")
        inertia, jacobian = random_inertias_and_jacobians(robot, count, rng)
        bases = [complete_qr(jacobian, np.zeros((count, robot.m)), True)[1]]
        velocity = rng.normal(size=(count, robot.nv)) * rng.uniform(0.01, 3.0, (count, 1))
    else:
        n = 7
        root = rng.normal(size=(count, n, n))
        inertia = root @ np.swapaxes(root, 1, 2) + 0.1 * np.eye(n)
        bases = [np.linalg.qr(rng.normal(size=(count, n, r)))[0] for r in (2, 3, 4, 5)]
        velocity = rng.normal(size=(count, n))
    for basis in bases:
        kinetic, energy = self_motion_energy(inertia, velocity, null_space_basis=basis)
        expected_kinetic, expected = self_motion_energy_by_solve(inertia, velocity, basis)
        assert np.all(np.abs(kinetic - expected_kinetic) <= 1e-12 * expected_kinetic)
        assert np.all(np.abs(energy - expected) <= 1e-12 * expected_kinetic)
        assert 0.01 < np.median(expected / expected_kinetic) < 1.0  # E_N a fair part of T, not all of it
    singular = np.array(bases[0])
    singular[:5, :, 1] = singular[:5, :, 0]
    kinetic, energy = self_motion_energy(inertia, velocity, null_space_basis=singular)
    expected_kinetic, expected = self_motion_energy_by_solve(inertia, velocity, singular)
    np.testing.assert_allclose(energy[5:], expected[5:], rtol=0, atol=1e-12 * expected_kinetic.max())
    np.testing.assert_allclose(energy[:5], expected[:5], rtol=1e-9)
    np.testing.assert_array_equal(kinetic[:5], expected_kinetic[:5])

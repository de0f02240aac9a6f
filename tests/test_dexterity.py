"""Dexterity measures against closed-form planar kinematics and dynamics, SVD and the paper's Eq. (6), Eq. (22), Eq. (23), Eq. (24), Eq. (25)."""

import numpy as np
import pytest

import torqueopt
from torqueopt.dexterity import DEXTERITY_COLUMNS, dexterity, dexterity_along

from .conftest import PAPER_Q0
from .test_dynamics import closed_form_gravity, closed_form_inertia, closed_form_jacobian

LIMITS = np.array([54.0, 24.0, 6.0])
#: In-plane gravity weak enough that every joint of planar3 can hold the arm (|g| < τ⁺ everywhere).
WEAK_GRAVITY = np.array([0.3, -0.4, 0.0])


def configurations(rng, count=12):
    return [rng.uniform(-np.pi, np.pi, 3) for _ in range(count)]


@pytest.fixture(scope="module")
def planar3_weak_gravity(planar3):
    return planar3.with_gravity(WEAK_GRAVITY)


def test_manipulability_is_eq_6_of_the_closed_form_jacobian(planar3, rng):
    for q in configurations(rng):
        jacobian = closed_form_jacobian(q)
        measured = dexterity(planar3, q)
        assert measured.manipulability == pytest.approx(np.sqrt(np.linalg.det(jacobian @ jacobian.T)), rel=1e-9)
        assert measured.manipulability == pytest.approx(np.prod(measured.singular_values), rel=1e-12)
        np.testing.assert_allclose(measured.singular_values, np.linalg.svd(jacobian, compute_uv=False), rtol=1e-9)
        assert measured.min_singular_value == pytest.approx(np.linalg.svd(jacobian, compute_uv=False)[-1], rel=1e-9)


def test_planar_manipulability_does_not_depend_on_the_first_joint(planar3, rng):
    q = rng.uniform(-np.pi, np.pi, 3)
    values = [dexterity(planar3, [q1, q[1], q[2]]) for q1 in np.linspace(-3.0, 3.0, 7)]
    for name in DEXTERITY_COLUMNS:
        np.testing.assert_allclose([getattr(v, name) for v in values], getattr(values[0], name), rtol=1e-9)


def test_the_straight_arm_is_singular(planar3):
    measured = dexterity(planar3, [0.3, 0.0, 0.0])
    assert measured.manipulability == pytest.approx(0.0, abs=1e-12)
    assert measured.min_singular_value == pytest.approx(0.0, abs=1e-12)
    assert measured.dynamic_manipulability == pytest.approx(0.0, abs=1e-9)
    assert measured.khatib_isotropy == pytest.approx(0.0, abs=1e-9)


def eq_25(jacobian, inertia, weight):
    """Eq. (25) as printed: w = sqrt(det(J (H̃ᵀH̃)⁻¹ Jᵀ)), H̃ = W H."""
    weighted = weight @ inertia
    return np.sqrt(np.linalg.det(jacobian @ np.linalg.inv(weighted.T @ weighted) @ jacobian.T))


def test_dynamic_manipulability_is_eq_25_with_yoshikawas_weights(planar3_weak_gravity, rng):
    robot = planar3_weak_gravity
    for q in configurations(rng):
        gravity = closed_form_gravity(q, WEAK_GRAVITY)
        assert np.all(np.abs(gravity) < LIMITS)
        measured = dexterity(robot, q)
        np.testing.assert_allclose(measured.gravity_torque, gravity, atol=1e-9)
        np.testing.assert_allclose(measured.torque_range, LIMITS - np.abs(gravity), atol=1e-9)
        weight = np.diag(1.0 / (LIMITS - np.abs(gravity)))  # W = diag(1/(τ⁺ᵢ − |gᵢ|))
        expected = eq_25(closed_form_jacobian(q), closed_form_inertia(q), weight)
        assert measured.dynamic_manipulability == pytest.approx(expected, rel=1e-8)
        # Symmetric limits: Khatib's min(|τ⁻ − g|, |τ⁺ − g|) is τ⁺ − |g|, the same index.
        assert measured.khatib_manipulability == pytest.approx(expected, rel=1e-8)


def test_operational_space_measure_is_the_closed_form_det_of_the_inverse_inertia(planar3, rng):
    for q in configurations(rng, 5):
        jacobian, inertia = closed_form_jacobian(q), closed_form_inertia(q)
        expected = np.sqrt(np.linalg.det(jacobian @ np.linalg.solve(inertia, jacobian.T)))
        assert dexterity(planar3, q).operational_space_manipulability == pytest.approx(expected, rel=1e-9)


def test_khatibs_normalisation_with_asymmetric_limits(planar3_weak_gravity, rng):
    robot = planar3_weak_gravity.with_gravity(WEAK_GRAVITY)
    lower = np.array([-20.0, -30.0, -2.0])
    robot.torque_lower = lower
    q = rng.uniform(-np.pi, np.pi, 3)
    gravity = closed_form_gravity(q, WEAK_GRAVITY)
    available = np.minimum(np.abs(lower - gravity), np.abs(LIMITS - gravity))
    measured = dexterity(robot, q)
    np.testing.assert_allclose(measured.khatib_torque_range, available, atol=1e-9)
    jacobian, inertia = closed_form_jacobian(q), closed_form_inertia(q)
    assert measured.khatib_manipulability == pytest.approx(eq_25(jacobian, inertia, np.diag(1 / available)), rel=1e-8)
    # Yoshikawa's index reads only τ⁺, so it is unchanged by the lower limits.
    assert measured.dynamic_manipulability == pytest.approx(
        eq_25(jacobian, inertia, np.diag(1 / (LIMITS - np.abs(gravity)))), rel=1e-8
    )
    values = np.linalg.svd(jacobian @ np.linalg.inv(np.diag(1 / available) @ inertia), compute_uv=False)
    assert measured.khatib_isotropy == pytest.approx(values[-1] / values[0], rel=1e-8)
    assert 0.0 < measured.khatib_isotropy <= 1.0


def test_ellipsoids_are_the_images_of_the_unit_ball(planar3_weak_gravity, rng):
    q = rng.uniform(-np.pi, np.pi, 3)
    measured = dexterity(planar3_weak_gravity, q)
    jacobian, inertia = closed_form_jacobian(q), closed_form_inertia(q)
    gravity = closed_form_gravity(q, WEAK_GRAVITY)
    mapping = jacobian @ np.linalg.inv(np.diag(1.0 / (LIMITS - np.abs(gravity))) @ inertia)  # J H̃⁻¹, Eq. (23)
    for ellipsoid, matrix in ((measured.velocity_ellipsoid, jacobian), (measured.acceleration_ellipsoid, mapping)):
        np.testing.assert_allclose(ellipsoid.axes.T @ ellipsoid.axes, np.eye(2), atol=1e-12)
        boundary = ellipsoid.outline(37)
        # Each boundary point is reached by a smallest joint input of norm exactly 1 ...
        smallest = np.linalg.pinv(matrix) @ boundary.T
        np.testing.assert_allclose(np.linalg.norm(smallest, axis=0), 1.0, rtol=1e-9)
        # ... and no unit input reaches beyond the boundary in any direction (support function).
        inputs = rng.normal(size=(3, 4000))
        reached = matrix @ (inputs / np.linalg.norm(inputs, axis=0))
        for direction in boundary[::6] / np.linalg.norm(boundary[::6], axis=1)[:, None]:
            support = np.linalg.norm(matrix.T @ direction)
            assert (direction @ reached).max() <= support * (1 + 1e-12)
    assert np.prod(measured.acceleration_ellipsoid.radii) == pytest.approx(measured.dynamic_manipulability, rel=1e-9)


def test_a_joint_that_cannot_hold_gravity_gives_no_range(planar3):
    heavy = planar3.with_gravity([0.0, -9.81, 0.0])
    measured = dexterity(heavy, [0.0, 0.0, 0.0])  # straight out, horizontal in the gravity plane
    assert measured.gravity_torque[2] == pytest.approx(10 * 9.81 * 0.5)
    assert measured.torque_range[2] == 0.0 and measured.khatib_torque_range[2] == 0.0
    assert measured.dynamic_manipulability == 0.0


def test_a_joint_without_torque_limit_makes_the_normalised_measures_nan(planar3):
    unlimited = planar3.with_torque_limit(np.array([54.0, np.inf, 6.0]))
    measured = dexterity(unlimited, PAPER_Q0)
    assert np.isnan(measured.dynamic_manipulability) and np.isnan(measured.khatib_manipulability)
    assert measured.acceleration_ellipsoid is None
    assert measured.manipulability > 0


def test_seven_joint_arm_against_an_independent_eq_25(panda):
    import pinocchio as pin

    q = panda.default_configuration
    measured = dexterity(panda, q)
    model = panda.model
    data = model.createData()
    inertia = pin.crba(model, data, q)
    inertia = np.triu(inertia) + np.triu(inertia, 1).T
    gravity = pin.rnea(model, data, q, np.zeros(7), np.zeros(7))  # τ at rest: g(q), Eq. (20)
    pin.framesForwardKinematics(model, data, q)
    jacobian = pin.computeFrameJacobian(model, data, q, panda.frame_id, pin.LOCAL_WORLD_ALIGNED)[:3]
    weight = np.diag(1.0 / (panda.torque_upper - np.abs(gravity)))
    assert measured.dynamic_manipulability == pytest.approx(eq_25(jacobian, inertia, weight), rel=1e-7)
    assert measured.manipulability == pytest.approx(np.sqrt(np.linalg.det(jacobian @ jacobian.T)), rel=1e-9)


def test_along_a_run_equals_pointwise(planar3, panda):
    line = torqueopt.StraightLine([1, 1], duration=0.2)
    result = torqueopt.simulate(planar3, "pinv", line, PAPER_Q0, dexterity=True)
    assert set(result.dexterity) == set(DEXTERITY_COLUMNS)
    for row in (0, 77, len(result.t) - 1):
        pointwise = dexterity(planar3, result.q[row]).measures()
        for name in DEXTERITY_COLUMNS:
            assert result.dexterity[name][row] == pytest.approx(pointwise[name], rel=1e-12, nan_ok=True)
    rows = np.vstack([panda.default_configuration, np.full(panda.nq, np.nan)])
    along = dexterity_along(panda, rows)
    assert np.isnan(along["manipulability"][1])
    assert along["manipulability"][0] == pytest.approx(dexterity(panda, rows[0]).manipulability)
    assert torqueopt.simulate(planar3, "pinv", line, PAPER_Q0).dexterity is None


def test_joint_angles_or_configuration_vectors(planar3):
    assert dexterity(planar3, PAPER_Q0).manipulability == dexterity(planar3, list(PAPER_Q0)).manipulability
    with pytest.raises(torqueopt.InvalidInput, match="q has 2 values but needs 3"):
        dexterity(planar3, [0.1, 0.2])


def test_result_files_keep_the_measures(planar3, tmp_path):
    result = torqueopt.simulate(
        planar3, "null-space", torqueopt.StraightLine([1, 1], duration=0.1), PAPER_Q0, dexterity=True
    )
    for name in ("run.npz", "run.csv"):
        loaded = torqueopt.load_result(result.to_csv(tmp_path / name))
        assert list(loaded.dexterity) == list(DEXTERITY_COLUMNS)
        for column in DEXTERITY_COLUMNS:
            np.testing.assert_allclose(loaded.dexterity[column], result.dexterity[column], rtol=1e-9)
        np.testing.assert_allclose(loaded.x_ref, result.x_ref, rtol=1e-9)
    header = (tmp_path / "run.csv").read_text().splitlines()[0].split(",")
    standard = len(result.csv_columns())
    assert header[:standard] == result.csv_columns() and header[standard:] == list(DEXTERITY_COLUMNS)
    plain = torqueopt.simulate(planar3, "pinv", torqueopt.StraightLine([1, 1], duration=0.1), PAPER_Q0)
    for name in ("plain.npz", "plain.csv"):
        assert torqueopt.load_result(plain.to_csv(tmp_path / name)).dexterity is None


def test_run_command_reports_and_records_the_measures_unless_told_not_to(tmp_path, capsys):
    from torqueopt.cli import main

    base = [
        "run",
        "--robot",
        "planar3",
        "--q0=-0.7853981634,2.3561944902,-2.3561944902",
        "--resolver",
        "pinv",
        "--direction",
        "1,1",
        "--duration",
        "0.1",
    ]
    assert main([*base, "--out", str(tmp_path / "with.npz")]) == 0
    printed = capsys.readouterr().out
    assert "manipulability w, Eq. (6): 1.225 at the start, lowest " in printed
    assert "dynamic manipulability, Eq. (25): 5.743 at the start" in printed
    assert torqueopt.load_result(tmp_path / "with.npz").dexterity["manipulability"][0] == pytest.approx(
        1.2247449, rel=1e-6
    )
    assert main([*base, "--no-dexterity", "--out", str(tmp_path / "without.npz")]) == 0
    assert "manipulability" not in capsys.readouterr().out
    assert torqueopt.load_result(tmp_path / "without.npz").dexterity is None


def test_a_joint_without_a_torque_limit_gives_nan_dynamic_measures_without_a_warning():
    """0 · inf in the torque-normalised map (a joint that does not move the task, without a limit) leaked
    "RuntimeWarning: invalid value encountered in multiply" into the run's output."""
    import warnings

    from torqueopt.dexterity import _measures

    jacobian = np.array([[[1.0, 0.0, 0.5], [0.0, 0.0, 1.0]]])  # joint 2 does not move the task
    inertia, gravity = np.eye(3)[None], np.zeros((1, 3))
    upper = np.array([54.0, np.inf, 6.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        measures = _measures(jacobian, inertia, gravity, upper, -upper)[0]
    assert np.isnan(measures["dynamic_manipulability"]).all()
    assert measures["manipulability"][0] == pytest.approx(1.0)

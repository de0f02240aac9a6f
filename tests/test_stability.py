"""The stability margin against finite differences of the whole closed loop, and the paper's Fig. 4.

The reference linearisation differences the closed loop itself, q̈ = F(q, q̇),
the resolver's joint acceleration at the terms Pinocchio computes at each
perturbed state: no ABA derivative and no term derivative is involved. The
task map (tip position and velocity) is differenced the same way.
"""

import numpy as np
import pinocchio as pin
import pytest
from scipy.linalg import null_space

import torqueopt
from torqueopt.paper import PAPER
from torqueopt.self_motion import self_motion
from torqueopt.stability import _term_derivatives, linearise, stability_margin
from torqueopt.whiplash import detect_whiplash


def _loop_by_differences(robot, resolver, q, v, xdd, h=1e-6, **options):
    step = torqueopt.get_resolver(resolver, **options).solver(robot)
    n = robot.nv

    def acceleration(qq, vv):
        return step(robot.terms(qq, vv), xdd).joint_acceleration

    def task(qq, vv):
        terms = robot.terms(qq, vv)
        return np.r_[terms.placement.translation[: robot.m], terms.jacobian @ vv]

    columns, task_columns = [], []
    for i in range(2 * n):
        e = np.zeros(2 * n)
        e[i] = 1.0
        plus = pin.integrate(robot.model, q, h * e[:n]), v + h * e[n:]
        minus = pin.integrate(robot.model, q, -h * e[:n]), v - h * e[n:]
        columns.append((acceleration(*plus) - acceleration(*minus)) / (2 * h))
        task_columns.append((task(*plus) - task(*minus)) / (2 * h))
    jacobian = np.block([[np.zeros((n, n)), np.eye(n)], [np.array(columns).T]])
    return jacobian, np.array(task_columns).T


def _states(robot, rng, count):
    for _ in range(count):
        q = robot.configuration(rng.uniform(-2.0, 2.0, robot.nv) if robot.nv == 3 else rng.uniform(-1.0, 1.0, robot.nv))
        yield q, 0.5 * rng.normal(size=robot.nv), rng.normal(size=robot.m)


def test_term_derivatives_against_finite_differences(panda, planar3, rng):
    for robot in (planar3, panda):
        q, v, _ = next(_states(robot, rng, 1))
        inertia_ds, bias_ds, jacobian_ds, drift_ds, velocity_ds = _term_derivatives(robot, q, v)
        n, h = robot.nv, 1e-6
        for i in range(2 * n):
            e = np.zeros(2 * n)
            e[i] = 1.0
            plus = robot.terms(pin.integrate(robot.model, q, h * e[:n]), v + h * e[n:])
            minus = robot.terms(pin.integrate(robot.model, q, -h * e[:n]), v - h * e[n:])
            for analytical, plus_value, minus_value in (
                (inertia_ds[:, :, i], plus.inertia, minus.inertia),
                (bias_ds[:, i], plus.bias_torque, minus.bias_torque),
                (jacobian_ds[:, :, i], plus.jacobian, minus.jacobian),
                (drift_ds[:, i], plus.drift, minus.drift),
                (velocity_ds[:, i], plus.jacobian @ plus.joint_velocity, minus.jacobian @ minus.joint_velocity),
            ):
                difference = (plus_value - minus_value) / (2 * h)
                np.testing.assert_allclose(analytical, difference, atol=1e-7 * (1 + np.abs(difference).max()))


@pytest.mark.parametrize(
    "robot_name, resolver, options",
    [
        ("planar3", "null-space", {}),
        ("planar3", "pinv", {}),
        ("planar3", "damped-null-space", {}),
        # The barrier binding (E_max below the state's E_N), the torque bounds far away.
        ("loose_planar3", "energy-bounded-torque", {"joint_limits": "off", "energy_limit": "half"}),
        pytest.param("planar3", "bounded-torque", {"joint_limits": "off"}, marks=pytest.mark.slow),
        pytest.param("panda", "weighted-null-space", {}, marks=pytest.mark.slow),
    ],
)
def test_the_margin_is_the_eigenvalue_of_the_differenced_closed_loop(robot_name, resolver, options, request, rng):
    if robot_name == "loose_planar3":
        robot = PAPER.load_robot().with_torque_limit(np.full(3, 1e4))
    elif robot_name == "planar3":
        robot = PAPER.load_robot()
    else:
        robot = request.getfixturevalue(robot_name)
    checked = 0
    for q, v, xdd in _states(robot, rng, 6):
        options = dict(options)
        if options.get("energy_limit") == "half":
            terms = robot.terms(q, v)
            options["energy_limit"] = 0.5 * self_motion(terms.inertia, null_space(terms.jacobian), v).energy
        # Where the resolver gives up part of the task the loop is only piecewise smooth: such states are left out.
        if torqueopt.get_resolver(resolver, **options).solver(robot)(robot.terms(q, v), xdd).infeasible:
            continue
        checked += 1
        found = linearise(robot, resolver, q, v, xdd, resolver_options=options)
        jacobian, task_map = _loop_by_differences(robot, resolver, q, v, xdd, **options)
        scale = 1.0 + np.abs(jacobian).max()
        np.testing.assert_allclose(found.state_jacobian, jacobian, atol=1e-6 * scale)
        basis = found.self_motion_basis
        assert basis.shape == (2 * robot.nv, 2 * (robot.nv - robot.m))
        np.testing.assert_allclose(task_map @ basis, 0.0, atol=1e-7)
        reference = np.linalg.eigvals(basis.T @ jacobian @ basis)
        assert found.margin == pytest.approx(reference.real.max(), abs=1e-6 * (1 + abs(found.margin)))
        assert found.margin == stability_margin(robot, resolver, q, v, xdd, resolver_options=options)
    assert checked >= 3, checked


def test_pinv_at_rest_has_no_growth(planar3):
    """At rest pinv's self-motion is y = 0: the linearised self-motion neither grows nor decays at first order."""
    robot = PAPER.load_robot()
    q = robot.configuration(PAPER.q0)
    margin = stability_margin(robot, "pinv", q, np.zeros(3), np.zeros(2))
    assert abs(margin) < 1e-6


def test_on_the_long_movement_the_margin_is_positive_before_null_space_whips():
    """The paper's Fig. 4: null-space's self-motion grows from the start and ever faster until the whip."""
    robot = PAPER.load_robot()
    line = PAPER.line("long")
    runs = {name: torqueopt.simulate(robot, name, line, PAPER.q0) for name in ("null-space", "pinv")}
    whip = detect_whiplash(runs["null-space"])
    assert whip.unstable and 1.2 < whip.time < 1.6
    assert not detect_whiplash(runs["pinv"]).unstable
    reference = line.anchored(runs["pinv"].x[0]).sample(runs["pinv"].t)
    margins = {}
    for name, run in runs.items():
        rows = np.flatnonzero(run.t < whip.time)[::50]
        margins[name] = np.array(
            [stability_margin(robot, name, run.q[k], run.v[k], reference.acceleration[k]) for k in rows]
        )
    early = slice(0, 10)  # the first half second
    assert np.all(margins["null-space"] > 0)
    assert margins["null-space"][-1] > 10 * margins["null-space"][0]
    assert np.all(margins["null-space"][early] > 10 * np.abs(margins["pinv"][early]))


def test_simulate_records_the_margin_of_every_applied_row_and_files_keep_it(tmp_path):
    robot = PAPER.load_robot()
    line = PAPER.line("short")
    run = torqueopt.simulate(robot, "null-space", line, PAPER.q0, duration=0.05, margin=True)
    assert run.stability_margin.shape == run.t.shape and np.isnan(run.stability_margin[-1])
    reference = line.anchored(run.x[0]).sample(run.t)
    for k in (0, 20, 49):
        expected = stability_margin(robot, "null-space", run.q[k], run.v[k], reference.acceleration[k])
        assert run.stability_margin[k] == pytest.approx(expected, rel=1e-12)
    assert torqueopt.simulate(robot, "null-space", line, PAPER.q0, duration=0.05).stability_margin is None
    for name in ("run.csv", "run.npz"):
        run.to_csv(tmp_path / name)
        back = torqueopt.load_result(tmp_path / name, robot)
        np.testing.assert_allclose(back.stability_margin, run.stability_margin, rtol=1e-9)
    with pytest.raises(torqueopt.InvalidInput, match="velocity level"):
        torqueopt.simulate(robot, "velocity-pinv", line, PAPER.q0, duration=0.05, margin=True)


def test_cli_run_margin_prints_and_writes_the_column(tmp_path, capsys):
    from torqueopt.cli import main

    out = tmp_path / "run.csv"
    code = main(["run", "--robot", "planar3", "--resolver", "null-space", "--direction", "1,1", "--duration", "0.05",
                 "--margin", "--out", str(out)])  # fmt: skip
    assert code == 0
    printed = capsys.readouterr().out
    assert "stability margin: largest" in printed and "first positive at t = 0.000 s" in printed
    assert "stability_margin" in out.read_text().splitlines()[0].split(",")

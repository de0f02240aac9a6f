"""simulate(): rows, tracking, early stops, files."""

import json

import numpy as np
import pytest

import torqueopt
from torqueopt import InvalidInput, StraightLine
from torqueopt.io import atomic_write
from torqueopt.whiplash import detect_whiplash

from .conftest import PAPER_Q0


@pytest.fixture(scope="module")
def short_pinv(planar3):
    return torqueopt.simulate(planar3, "pinv", StraightLine([1, 1], duration=0.5), PAPER_Q0)


def test_rows_follow_the_steps_and_the_tip_tracks_open_loop(short_pinv):
    result = short_pinv
    assert result.completed and result.stop_reason is None
    assert len(result.t) == 501 and result.t[-1] == pytest.approx(0.5)
    np.testing.assert_allclose(np.diff(result.t), 1e-3)
    np.testing.assert_allclose(result.x[0], [np.sqrt(2), 1 - np.sqrt(2)], atol=1e-9)
    np.testing.assert_allclose(result.x_ref[-1] - result.x_ref[0], [0.0625, 0.0625], atol=1e-12)
    assert result.max_tip_error < 2e-3
    np.testing.assert_allclose(result.v[0], 0.0)
    # The commanded joint accelerations integrate to the recorded velocities.
    velocity_from_acceleration = np.cumsum(result.acceleration[:-1], axis=0) * 1e-3
    np.testing.assert_allclose(result.v[1:], velocity_from_acceleration, atol=5e-3)


def test_summary_figures_agree_with_the_arrays(short_pinv):
    result = short_pinv
    # The last row is the final state: no torque is applied from it.
    assert np.isnan(result.tau[-1]).all() and np.isfinite(result.tau[:-1]).all()
    np.testing.assert_allclose(result.peak_torque, np.abs(result.tau[:-1]).max(axis=0))
    np.testing.assert_allclose(result.peak_torque_ratio, result.peak_torque / np.array([54.0, 24.0, 6.0]))
    assert result.first_limit_violation is None
    summary = result.summary()
    assert summary["resolver"] == "pinv" and summary["completed"] is True
    assert summary["torque_limit"] == [54.0, 24.0, 6.0]


def test_feedback_cuts_the_tip_error(planar3, short_pinv):
    closed = torqueopt.simulate(planar3, "pinv", StraightLine([1, 1], duration=0.5), PAPER_Q0, feedback=(400.0, 40.0))
    assert closed.max_tip_error < 0.2 * short_pinv.max_tip_error


def test_csv_has_the_named_columns_and_reads_back(tmp_path, short_pinv):
    path = short_pinv.to_csv(tmp_path / "run.csv")
    header = path.read_text().splitlines()[0]
    assert header == "t,q1,q2,q3,v1,v2,v3,tau1,tau2,tau3,x1,x2,xref1,xref2,task_error,infeasible"
    table = np.loadtxt(path, delimiter=",", skiprows=1)
    assert table.shape == (501, 16)
    np.testing.assert_array_equal(table[:, 14:], 0.0)  # pinv realises its task at every step
    np.testing.assert_allclose(table[:, 7:10], short_pinv.tau, rtol=1e-9, atol=1e-12)
    assert json.loads((tmp_path / "run.csv.json").read_text())["resolver"] == "pinv"
    back = torqueopt.load_result(path)
    np.testing.assert_allclose(back.joint_angles, short_pinv.joint_angles, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(back.torque_upper, [54, 24, 6])


def test_a_run_file_without_the_task_columns_is_refused_as_malformed(tmp_path, short_pinv):
    """Every file this package writes has task_error and infeasible: one without them was not written by it."""
    path = short_pinv.to_csv(tmp_path / "run.csv")
    lines = path.read_text().splitlines()
    path.write_text("\n".join(line.rsplit(",", 2)[0] for line in lines) + "\n")
    with pytest.raises(
        torqueopt.InvalidInput, match=r"its header has no column task_error, infeasible; a run of 3 joints"
    ):
        torqueopt.load_result(path)
    archive = tmp_path / "old.npz"
    arrays = {name: getattr(short_pinv, name) for name in ("t", "q", "joint_angles", "v", "acceleration", "tau", "x",
                                                            "x_ref", "torque_upper", "torque_lower")}  # fmt: skip
    arrays["jacobian_condition"] = short_pinv.jacobian_inverse_condition
    metadata = {key: value for key, value in short_pinv.summary().items() if key in ("robot", "frame", "task", "resolver",
                                                                                       "joint_names", "duration")}  # fmt: skip
    metadata.update(dt=short_pinv.dt, stop_reason=None, stop_time=None)
    np.savez_compressed(archive, metadata=json.dumps(metadata), **arrays)
    with pytest.raises(torqueopt.InvalidInput, match=r"is malformed \(missing field .*jacobian_inverse_condition"):
        torqueopt.load_result(archive)


def test_task_error_and_infeasible_rows_are_kept_and_summarised(tmp_path, planar3):
    """A resolver that gives up part of the task says so per step; simulate keeps it, files keep it."""

    class HalfTask(torqueopt.Resolver):
        """Realises half the task acceleration on odd steps and calls them infeasible."""

        name = "half-task"

        def solver(self, robot):
            full = torqueopt.get_resolver("pinv").solver(robot)
            calls = []

            def step(terms, task_acceleration):
                calls.append(None)
                if len(calls) % 2:
                    return full(terms, task_acceleration)
                half = full(terms, 0.5 * task_acceleration + 0.5 * terms.drift)
                error = float(np.linalg.norm(0.5 * (task_acceleration - terms.drift)))
                return half._replace(task_error=error, infeasible=True)

            return step

    result = torqueopt.simulate(planar3, HalfTask(), StraightLine([1, 1], duration=0.01), PAPER_Q0)
    assert result.infeasible.tolist() == [False, True] * 5 + [False]
    assert result.task_error[0] == 0.0 and result.task_error[1] == pytest.approx(
        0.5 * np.sqrt(2.0), rel=1e-3
    )  # half of √2 m/s², J̇q̇ ≈ 0
    assert result.summary()["infeasible_steps"] == 5 and result.max_task_error == result.task_error.max() > 0
    for name in ("run.csv", "run.npz"):
        back = torqueopt.load_result(result.to_csv(tmp_path / name))
        np.testing.assert_array_equal(back.infeasible, result.infeasible)
        np.testing.assert_allclose(back.task_error, result.task_error, rtol=1e-9)
    # The overview figure draws the shortfall on a second axis of the tip-error panel.
    from torqueopt import plots

    figure = plots.plot_run(result, tmp_path / "run.png")
    assert figure.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_npz_keeps_everything(tmp_path, short_pinv):
    back = torqueopt.load_result(short_pinv.to_csv(tmp_path / "run.npz"))
    for name in (
        "t",
        "q",
        "v",
        "acceleration",
        "tau",
        "x",
        "x_ref",
        "jacobian_inverse_condition",
        "task_error",
        "infeasible",
    ):
        np.testing.assert_array_equal(getattr(back, name), getattr(short_pinv, name))
    assert back.summary() == short_pinv.summary()


def test_failed_write_leaves_no_file(tmp_path):
    target = tmp_path / "out.csv"

    def explode(handle):
        handle.write(b"partial")
        raise RuntimeError("disk full")

    with pytest.raises(RuntimeError):
        atomic_write(target, explode)
    assert list(tmp_path.iterdir()) == []


def test_explosion_stops_the_run_and_keeps_finite_rows(planar3):
    """The weighted null-space method blows up on the paper's long movement:
    with a torque ceiling of 20x the limits the run must stop, say when, and
    keep only finite rows up to that point."""
    result = torqueopt.simulate(
        planar3, "weighted-null-space", StraightLine([1, 1], duration=2.0), PAPER_Q0, max_torque_ratio=20.0
    )
    assert not result.completed
    assert 0.5 < result.stop_time < 2.0
    assert result.stop_reason.startswith("torque of joint joint")
    assert f"at t = {result.stop_time:.4f} s" in result.stop_reason
    # The run keeps every row up to the stop, and the stop's own row holds the torque that ended it.
    assert len(result.t) == round(result.stop_time / 1e-3) + 1 and result.t[-1] == pytest.approx(result.stop_time)
    for array in (result.q, result.v, result.tau, result.x):
        assert np.isfinite(array).all()
    last = result.torque_ratio[-1]
    assert last.max() > 20.0 and (result.torque_ratio[:-1] <= 20.0).all()
    # Peaks, the first violation and the whiplash verdict count that torque.
    assert result.peak_torque_ratio.max() == last.max()
    assert result.first_limit_violation is not None and result.first_limit_violation <= result.stop_time
    assert detect_whiplash(result).unstable


class _Overdriven(torqueopt.NullSpaceResolver):
    """Realises the task plus a null-space acceleration of ``size`` rad/s²."""

    name = "overdriven"

    def __init__(self, size: float):
        super().__init__()
        self.size = size

    def null_space_function(self, robot):
        return lambda terms, basis, particular: np.full(robot.redundancy, self.size)


@pytest.mark.filterwarnings("ignore:invalid value encountered:RuntimeWarning")
def test_non_finite_torque_stops_the_run_at_its_first_row(planar3):
    result = torqueopt.simulate(planar3, _Overdriven(np.inf), StraightLine([1, 1]), PAPER_Q0, max_torque_ratio=np.inf)
    assert result.stop_reason == "torque became non-finite at t = 0.0000 s"
    # The start state is kept, with the torque that stopped the run.
    assert result.stop_time == 0.0 and len(result.t) == 1
    np.testing.assert_allclose(result.joint_angles[0], PAPER_Q0)
    assert not np.isfinite(result.tau[0]).all()


def test_non_finite_state_stops_the_run_at_the_step_that_made_it(planar3):
    """With both explosion guards off, a finite but absurd torque (~1e300 N·m)
    makes RK4's stage velocities overflow within the first step: the run must
    stop after that step, name it, and keep the one finite row before it."""
    result = torqueopt.simulate(
        planar3, _Overdriven(1e300), StraightLine([1, 1]), PAPER_Q0, max_joint_speed=np.inf, max_torque_ratio=np.inf
    )
    assert result.stop_reason == "state became non-finite during the step from t = 0.0000 s"
    assert result.stop_time == pytest.approx(1e-3)
    assert len(result.t) == 1 and np.isfinite(result.tau).all() and np.abs(result.tau).max() > 1e299


def test_singular_jacobian_stops_the_run(planar3):
    """Pushing the tip towards the arm's 3 m reach straightens it: with a
    cutoff of 0.02 on σ_min/σ_max the run stops there and says so."""
    resolver = torqueopt.get_resolver("pinv", singular_tolerance=0.02)
    result = torqueopt.simulate(planar3, resolver, StraightLine([1, 0], accel=1.0, duration=3.0), [0.0, 1.0, -1.0])
    assert not result.completed
    assert result.stop_reason.startswith("task Jacobian is singular: smallest/largest singular value")
    assert result.stop_reason.endswith(f"is below the cutoff 0.02 at t = {result.stop_time:.4f} s")
    assert 0.5 < result.stop_time < 1.0
    # Every row before the stop had a usable Jacobian and a torque; the stop's
    # row keeps the singular state, with its condition and no torque.
    assert result.jacobian_inverse_condition[:-1].min() >= 0.02 and result.jacobian_inverse_condition[0] > 0.1
    assert result.jacobian_inverse_condition[-1] < 0.02 and result.t[-1] == pytest.approx(result.stop_time)
    assert np.isfinite(result.tau[:-1]).all() and np.isnan(result.tau[-1]).all()


@pytest.mark.parametrize("robot_name", ["panda", "xarm7"])
@pytest.mark.parametrize("name", ["pinv", "inertia-pinv"])
def test_pseudoinverses_track_on_7dof_arms(robot_name, name, request):
    robot = request.getfixturevalue(robot_name)
    line = StraightLine([0, 1, 0], duration=0.5)
    q0 = robot.default_configuration
    open_loop = torqueopt.simulate(robot, name, line, q0)
    closed = torqueopt.simulate(robot, name, line, q0, feedback=(400.0, 40.0))
    assert open_loop.completed and open_loop.max_tip_error < 5e-3
    assert closed.completed and closed.max_tip_error < 1e-4


# receding-horizon plans positions only (xy and position tasks; its refusal of pose is tested with it)
@pytest.mark.parametrize("name", [name for name in torqueopt.resolver_names("torque") if name != "receding-horizon"])
def test_every_resolver_tracks_a_pose_on_panda(name, panda_pose):
    line = StraightLine([0, 1, 0], duration=0.5)
    result = torqueopt.simulate(panda_pose, name, line, panda_pose.default_configuration, feedback=(400.0, 40.0))
    assert result.completed
    assert result.max_tip_error < 1e-4 and result.max_orientation_error < 1e-4
    np.testing.assert_allclose(result.x_ref[:, 3:], 0.0)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"q0": [0.1, 0.2]}, r"q0 has 2 values but needs 3 \(joints joint1, joint2, joint3\)"),
        ({"q0": [0.1, float("nan"), 0.3]}, r"q0 \[0.1, nan, 0.3\] has a non-finite value"),
        ({"q0": ["a", 1, 2]}, "q0 .* is not a vector of numbers"),
        ({"dt": 0.0}, r"dt=0.0 must be a positive finite number \[s\]"),
        ({"dt": -1e-3}, r"dt=-0.001 must be a positive finite number \[s\]"),
        ({"v0": [0, 0]}, "v0 has 2 values but needs 3"),
    ],
)
def test_bad_simulation_input(planar3, kwargs, message):
    arguments = {"q0": PAPER_Q0, **kwargs}
    with pytest.raises(InvalidInput, match=message):
        torqueopt.simulate(planar3, "pinv", StraightLine([1, 1], duration=0.5), **arguments)


def test_direction_must_fit_the_task(planar3, panda):
    with pytest.raises(
        InvalidInput, match="trajectory StraightLine moves in 3 dimensions but task 'xy' moves the tip in 2"
    ):
        torqueopt.simulate(planar3, "pinv", StraightLine([1, 1, 0], duration=0.5), PAPER_Q0)


def test_csv_of_continuous_joints_rebuilds_configurations_and_files_are_not_private(tmp_path):
    kinova = torqueopt.load_robot("kinova", gravity=False)
    result = torqueopt.simulate(
        kinova, "pinv", StraightLine([0, 0, 1], accel=0.5, duration=0.05), kinova.default_configuration
    )
    path = result.to_csv(tmp_path / "kinova.csv")
    back = torqueopt.load_result(path, robot=kinova)
    assert back.q.shape == result.q.shape == (51, kinova.nq)
    np.testing.assert_allclose(back.q, result.q, atol=1e-9)
    assert (path.stat().st_mode & 0o777) == 0o666 & ~_umask()


def _umask():
    import os

    mask = os.umask(0)
    os.umask(mask)
    return mask


@pytest.mark.parametrize(
    "damage, message",
    [
        (lambda csv, sidecar: sidecar.write_text("{not json"), r"is malformed \(Expecting property name"),
        (
            lambda csv, sidecar: sidecar.write_text('{"robot": "planar3"}'),
            r"is malformed \(missing field 'joint_names'\); write runs with torqueopt run --out",
        ),
        (lambda csv, sidecar: csv.write_text("t,q1\n0,abc\n"), "is malformed"),
        (lambda csv, sidecar: sidecar.unlink(), "has no sidecar"),
    ],
)
def test_damaged_run_files_give_one_clear_error(tmp_path, short_pinv, damage, message):
    csv = short_pinv.to_csv(tmp_path / "run.csv")
    damage(csv, tmp_path / "run.csv.json")
    with pytest.raises(InvalidInput, match=message):
        torqueopt.load_result(csv)
    broken_npz = tmp_path / "run.npz"
    broken_npz.write_bytes(b"PK\x03\x04 not really a zip")
    with pytest.raises(InvalidInput, match="run file '.*run.npz' is malformed"):
        torqueopt.load_result(broken_npz)


def test_runs_in_threads_on_one_robot_give_the_serial_results():
    """Each run computes in its own Pinocchio data, so two threads sharing a Robot cannot race."""
    import threading

    robot = torqueopt.load_robot("panda", task="position")
    movements = [
        ("null-space", StraightLine([1.0, 0.0, 0.0], accel=0.2, duration=0.3)),
        ("inertia-pinv", StraightLine([0.0, 0.6, 0.8], accel=0.3, duration=0.3)),
    ]
    q0 = robot.default_configuration
    serial = [torqueopt.simulate(robot, name, line, q0) for name, line in movements]
    threaded = [None, None]
    barrier = threading.Barrier(len(movements))

    def run(index):
        barrier.wait()
        name, line = movements[index]
        threaded[index] = torqueopt.simulate(robot, name, line, q0)

    threads = [threading.Thread(target=run, args=(index,)) for index in range(len(movements))]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    for alone, together in zip(serial, threaded):
        for field in ("q", "v", "tau", "x"):
            np.testing.assert_array_equal(getattr(together, field), getattr(alone, field))


@pytest.mark.parametrize("resolver", ["null-space", "velocity-pinv"])
def test_memory_follows_the_steps_taken_not_the_requested_duration(planar3, resolver):
    """Duration 1e5 s at 1 ms (1e8 steps, about 5 GB of reference at once) with no step
    limit, stopped by the speed ceiling within a second: the run holds a few blocks of rows, not the duration."""
    import tracemalloc

    line = torqueopt.StraightLine((1.0, 1.0), duration=2.0)
    tracemalloc.start()
    try:
        result = torqueopt.simulate(
            planar3, resolver, line, PAPER_Q0, duration=1e5, max_steps=10**30, max_joint_speed=1.0
        )
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert result.stop_reason is not None and "speed of joint" in result.stop_reason
    assert len(result.t) < 1000
    assert result.x_ref.shape == result.x.shape
    assert peak < 10e6, peak

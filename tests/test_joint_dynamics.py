"""Joint damping and friction from the URDF (``joint_dynamics``): the controller's bias, both plants, the files.

The independent checks: the forward dynamics against M⁻¹(τ − b − D q̇ − F tanh(q̇/v_s)) from Pinocchio's
CRBA and RNEA of the same arm without them; the energy balance of a free, gravity-free swing, whose kinetic
energy falls at the rate q̇ᵀ(D q̇ + F tanh(q̇/v_s)) (q̇ᵀD q̇ with damping alone); MuJoCo's own damping against
the Pinocchio plant over a whole run.
"""

import re
import warnings

import numpy as np
import pinocchio as pin
import pytest

import torqueopt
from torqueopt import StraightLine, simulate
from torqueopt.batch import simulate_batch
from torqueopt.cli import main
from torqueopt.errors import InvalidInput
from torqueopt.robot import FRICTION_RATE
from torqueopt.stability import linearise

DAMPING = (2.0, 1.5, 0.5)  # N·m·s/rad
FRICTION = (3.0, 1.0, 0.4)  # N·m
LINE = StraightLine(direction=[1, 1], accel=1.0, duration=0.3)
Q0 = np.array([-0.7853981634, 2.3561944902, -2.3561944902])


def planar3_with(tmp_path, damping, friction):
    """robots/planar3.urdf with ``<dynamics damping friction>`` on each joint."""
    text = torqueopt.load_robot("planar3").source.urdf.read_text()
    for index, (d, f) in enumerate(zip(damping, friction), start=1):
        text = re.sub(
            rf'(<joint name="joint{index}" type="revolute">)', rf'\1<dynamics damping="{d}" friction="{f}"/>', text
        )
    path = tmp_path / "planar3_damped.urdf"
    path.write_text(text)
    return path


@pytest.fixture
def damped_planar3(tmp_path):
    return torqueopt.load_robot(planar3_with(tmp_path, DAMPING, FRICTION), frame="tip", task="xy",
                                joint_dynamics="urdf")  # fmt: skip


def resistance(robot, v):
    """D q̇ + F tanh(q̇/v_s) from the definition, v_s = F (M⁻¹)_jj(q_ref) / κ."""
    inverse_inertia = np.linalg.inv(pin.crba(robot.model, robot.model.createData(), robot.default_configuration))
    scale = np.array(FRICTION) * np.diag(inverse_inertia) / FRICTION_RATE
    return np.array(DAMPING) * v + np.array(FRICTION) * np.tanh(v / scale)


def test_bias_and_forward_dynamics_carry_the_urdfs_damping_and_friction(damped_planar3, rng):
    plain = torqueopt.load_robot("planar3")
    assert not plain.urdf_has_joint_dynamics and plain.joint_dynamics == "off"
    np.testing.assert_array_equal(damped_planar3.urdf_joint_damping, DAMPING)
    for _ in range(5):
        q = damped_planar3.configuration(rng.uniform(-3, 3, 3))
        v, tau = rng.uniform(-2, 2, 3), rng.uniform(-20, 20, 3)
        model, data = plain.model, plain.model.createData()
        inertia = pin.crba(model, data, q)
        inertia = np.triu(inertia) + np.triu(inertia, 1).T
        bias = pin.rnea(model, data, q, v, np.zeros(3))
        joint = resistance(damped_planar3, v)
        terms = damped_planar3.terms(q, v)
        np.testing.assert_allclose(terms.bias_torque, bias + joint, rtol=0, atol=1e-12)
        expected = np.linalg.solve(inertia, tau - bias - joint)
        np.testing.assert_allclose(damped_planar3.forward_dynamics(q, v, tau), expected, rtol=0, atol=1e-10)
        off = damped_planar3.with_joint_dynamics("off")
        np.testing.assert_array_equal(off.terms(q, v).bias_torque, plain.terms(q, v).bias_torque)


@pytest.mark.parametrize("friction", [(0.0, 0.0, 0.0), FRICTION])
def test_a_free_swing_loses_the_energy_its_damping_and_friction_take(tmp_path, friction):
    # τ = 0, gravity off: dE/dt = −q̇ᵀ τ_j(q̇), the whole of the kinetic energy's change.
    robot = torqueopt.load_robot(planar3_with(tmp_path, DAMPING, friction), frame="tip", task="xy",
                                 joint_dynamics="urdf", gravity=False)  # fmt: skip
    plant = torqueopt.plants.PinocchioPlant(robot)
    dt = 1e-4
    q, v = robot.configuration(Q0), np.array([1.0, -2.0, 3.0])
    model, data = robot.model, robot.model.createData()
    energy = [pin.computeKineticEnergy(model, data, q, v)]
    power = [v @ robot.joint_resistance(v)]
    for _ in range(2000):
        q, v = plant.step(q, v, np.zeros(3), dt)
        energy.append(pin.computeKineticEnergy(model, data, q, v))
        power.append(v @ robot.joint_resistance(v))
    dissipated = dt * (np.sum(power) - 0.5 * (power[0] + power[-1]))  # trapezoid of q̇ᵀ τ_j
    assert energy[0] - energy[-1] > 0.02 * energy[0]  # the joints did take energy out
    assert abs(energy[0] - energy[-1] - dissipated) < 1e-6 * energy[0]


@pytest.mark.parametrize("resolver", ["null-space", "damped-null-space"])
def test_the_stability_margin_linearises_the_loop_with_its_joint_dynamics(damped_planar3, resolver, rng):
    # The reference differences the closed loop q̈ = ABA(q, q̇, τ(q, q̇) − τ_j(q̇)) of the resolver's torque.
    robot, n, h = damped_planar3, 3, 1e-6
    step = torqueopt.get_resolver(resolver).solver(robot)

    def acceleration(q, v, xdd):
        return robot.forward_dynamics(q, v, step(robot.terms(q, v), xdd).torque)

    for _ in range(3):
        q, v, xdd = robot.configuration(rng.uniform(-2, 2, n)), rng.normal(scale=0.05, size=n), rng.normal(size=2)
        columns = []
        for i in range(2 * n):
            e = h * np.eye(2 * n)[i]
            columns.append(
                (acceleration(q + e[:n], v + e[n:], xdd) - acceleration(q - e[:n], v - e[n:], xdd)) / (2 * h)
            )
        found = linearise(robot, resolver, q, v, xdd)
        np.testing.assert_allclose(found.state_jacobian[n:], np.array(columns).T, atol=2e-5 * np.abs(columns).max())


def test_the_resolver_contract_holds_on_an_arm_with_joint_dynamics(damped_planar3):
    from torqueopt.testing import check_resolver

    report = check_resolver("null-space", damped_planar3)  # raises ContractViolation on a broken contract
    assert "task" in report.checks


def test_off_is_the_arm_without_them_bit_for_bit(tmp_path):
    off = torqueopt.load_robot(planar3_with(tmp_path, DAMPING, FRICTION), frame="tip", task="xy")
    plain = torqueopt.load_robot("planar3")
    assert off.joint_dynamics == "off" and not off.models_joint_dynamics
    run, reference = simulate(off, "null-space", LINE, Q0), simulate(plain, "null-space", LINE, Q0)
    np.testing.assert_array_equal(run.tau, reference.tau)
    assert run.joint_dynamics["modelled"] is False and reference.joint_dynamics is None


@pytest.mark.slow
def test_the_batch_and_the_velocity_level_follow_the_robot(damped_planar3):
    lines = [LINE, StraightLine(direction=[1, -1], accel=0.5, duration=0.3)]
    batch = simulate_batch(damped_planar3, "null-space", lines, [Q0, Q0])
    for line, batched in zip(lines, batch):
        alone = simulate(damped_planar3, "null-space", line, Q0)
        np.testing.assert_allclose(batched.joint_angles, alone.joint_angles, rtol=0, atol=1e-12)
    modelled = simulate(damped_planar3, "velocity-pinv", LINE, Q0)
    ignored = simulate(damped_planar3.with_joint_dynamics("off"), "velocity-pinv", LINE, Q0)
    np.testing.assert_array_equal(modelled.joint_angles, ignored.joint_angles)  # the motion is the rates'
    np.testing.assert_allclose(modelled.tau - ignored.tau, resistance(damped_planar3, modelled.v), atol=1e-10)


def test_the_run_file_holds_the_damping_and_friction_torques(damped_planar3, tmp_path):
    run = simulate(damped_planar3, "pinv", LINE, Q0)
    applied = np.isfinite(run.tau).all(axis=1)
    np.testing.assert_allclose(run.damping_torque[applied], np.array(DAMPING) * run.v[applied], rtol=1e-15)
    np.testing.assert_allclose(
        run.damping_torque[applied] + run.friction_torque[applied], resistance(damped_planar3, run.v[applied])
    )
    path = run.to_csv(tmp_path / "run.csv")
    header = path.read_text().splitlines()[0].split(",")
    assert header[-6:] == ["damping1", "damping2", "damping3", "friction1", "friction2", "friction3"]
    back = torqueopt.load_result(path)
    assert back.joint_dynamics == run.joint_dynamics
    np.testing.assert_allclose(back.damping_torque[applied], run.damping_torque[applied], rtol=1e-9)
    assert run.summary()["joint_dynamics"]["peak_friction_torque"] == pytest.approx(
        np.abs(run.friction_torque[applied]).max(axis=0).tolist()
    )


@pytest.mark.slow
def test_the_cli_switch_and_its_bad_values(tmp_path, capsys):
    urdf = planar3_with(tmp_path, DAMPING, FRICTION)
    base = ["run", "--robot", str(urdf), "--frame", "tip", "--task", "xy", "--resolver", "pinv",
            "--q0=-0.7853981634,2.3561944902,-2.3561944902", "--direction", "1,1", "--duration", "0.3", "--no-dexterity"]  # fmt: skip
    out = tmp_path / "damped.csv"
    assert main([*base, "--joint-dynamics", "urdf", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "friction 3, 1, 0.4 N·m modelled (--joint-dynamics urdf)" in printed
    # The line's damping peak is D|q̇| at its largest over the run's own velocities, at the joint it names.
    run = torqueopt.load_result(out)
    named = re.search(r"largest at joint (\w+): damping up to ([\d.]+) N·m", printed)
    joint = run.joint_names.index(named.group(1))
    assert float(named.group(2)) == pytest.approx(DAMPING[joint] * np.abs(run.v[:, joint]).max(), rel=1e-3)
    assert main(base) == 0
    assert "NOT modelled (--joint-dynamics off)" in capsys.readouterr().out
    with pytest.raises(SystemExit) as stopped:
        main([*base, "--joint-dynamics", "on"])
    assert stopped.value.code == 2
    error = capsys.readouterr().err.strip().splitlines()
    assert len(error) == 1 and "--joint-dynamics: invalid choice: 'on' (choose from 'urdf', 'off')" in error[0]
    with pytest.raises(InvalidInput, match=r"^joint dynamics 'on' is not one of urdf, off$"):
        torqueopt.load_robot("planar3", joint_dynamics="on")


def test_the_atlas_robot_spec_carries_the_switch(tmp_path):
    from torqueopt.atlas.jobs import RobotSpec

    urdf = str(planar3_with(tmp_path, DAMPING, FRICTION))
    spec = RobotSpec(urdf, frame="tip", task="xy", joint_dynamics="urdf")
    assert spec.load().models_joint_dynamics and spec.as_dict()["joint_dynamics"] == "urdf"
    assert RobotSpec(**spec.as_dict()) == spec
    # An atlas that never set it keeps the record it had.
    assert "joint_dynamics" not in RobotSpec("planar3").as_dict()
    assert not RobotSpec(urdf, frame="tip", task="xy").load().models_joint_dynamics


def test_the_whole_movement_optimum_refuses_an_arm_whose_joint_dynamics_it_does_not_model(damped_planar3, tmp_path):
    from torqueopt.optimal import optimize

    with pytest.raises(InvalidInput, match="models its URDF's joint damping and friction"):
        optimize(damped_planar3, LINE, Q0)
    with pytest.raises(InvalidInput, match="models its URDF's joint damping and friction"):
        simulate(damped_planar3, "receding-horizon", LINE, Q0)  # its windows are the same problem
    urdf = str(planar3_with(tmp_path, DAMPING, FRICTION))
    out = tmp_path / "atlas"
    arguments = ["atlas", "--robot", urdf, "--frame", "tip", "--task", "xy", "--paths", "1", "--durations", "0.3"]
    assert main([*arguments, "--global", "--joint-dynamics", "urdf", "--out", str(out)]) == 2
    assert not out.exists()  # refused before any work


def test_a_run_says_when_the_joint_damping_is_too_stiff_for_rk4s_step():
    from torqueopt.simulate import RK4_REAL_STABILITY, joint_dynamics_rate

    # RK4's amplification on y' = −λy is the Taylor polynomial of e^(−hλ): |R| = 1 at the stability bound.
    x = -RK4_REAL_STABILITY
    assert abs(abs(1 + x + x**2 / 2 + x**3 / 6 + x**4 / 24) - 1) < 2e-3
    robot = torqueopt.load_robot("xarm7", joint_dynamics="urdf")
    q = robot.default_configuration
    inertia = pin.crba(robot.model, robot.model.createData(), q)
    inertia = np.triu(inertia) + np.triu(inertia, 1).T
    slope = robot.urdf_joint_damping + robot.joint_friction / robot.friction_velocity_scale
    rate = np.linalg.eigvals(np.linalg.solve(inertia, np.diag(slope))).real.max()
    assert joint_dynamics_rate(robot, inertia) == pytest.approx(rate, rel=1e-12) and rate * 1e-3 > RK4_REAL_STABILITY
    line = StraightLine([0, 0, 1], duration=0.01)
    with pytest.warns(torqueopt.TorqueoptWarning, match="stiff for dt=0.001 s"):
        simulate(robot, "pinv", line, q, dt=1e-3)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        simulate(robot, "pinv", line, q, dt=line.duration / np.ceil(line.duration * rate / RK4_REAL_STABILITY))
        simulate(torqueopt.load_robot("xarm7"), "pinv", line, q, dt=1e-3)  # off: nothing to be stiff


mujoco = pytest.importorskip("mujoco")
#: MuJoCo's plant matched to Pinocchio's (its damping option left to follow the robot).
MATCHED = {"contacts": "off", "joint-limits": "off", "integrator": "rk4"}
XARM_LINE = StraightLine(direction=[0, 1, -1], accel=1.0, duration=0.5)


def test_the_mujoco_plant_follows_the_switch_unless_told(xarm7):
    from torqueopt.plants.mujoco import MujocoPlant

    modelled = xarm7.with_joint_dynamics("urdf")
    plants = {
        "off": MujocoPlant(xarm7),
        "urdf": MujocoPlant(modelled),
        "off, damping=urdf": MujocoPlant(xarm7, damping="urdf"),
        "urdf, damping=zero": MujocoPlant(modelled, damping="zero"),
    }
    for label, applied in [("off", False), ("urdf", True), ("off, damping=urdf", True), ("urdf, damping=zero", False)]:
        plant = plants[label]
        expected = (xarm7.urdf_joint_damping, xarm7.urdf_joint_friction) if applied else (np.zeros(7), np.zeros(7))
        np.testing.assert_array_equal(plant.model.dof_damping, expected[0], err_msg=label)
        np.testing.assert_array_equal(plant.model.dof_frictionloss, expected[1], err_msg=label)
        assert plant.record()["damping"] == ("urdf" if applied else "zero")


@pytest.mark.slow
def test_mujocos_damping_is_the_pinocchio_plants_on_xarm7(xarm7):
    # xarm7's own URDF: damping 10, 10, 5, 5, 5, 2, 2 N·m·s/rad (its friction set aside on a model copy).
    damped = xarm7.with_gravity(True)
    damped.model.friction[:] = 0.0
    damped = damped.with_joint_dynamics("urdf")
    reference = simulate(damped, "pinv", XARM_LINE, damped.default_configuration)
    run = simulate(damped, "pinv", XARM_LINE, damped.default_configuration, plant="mujoco", plant_options=MATCHED)
    assert run.plant["damping"] == "urdf" and reference.completed and run.completed
    np.testing.assert_array_equal(damped.joint_damping, [10.0, 10.0, 5.0, 5.0, 5.0, 2.0, 2.0])
    assert np.abs(run.joint_angles - reference.joint_angles).max() < 1e-9
    # A controller that ignores it leaves joint7's damping (D/H ≈ 1.5e4 /s) to MuJoCo's explicit RK4 at 1 ms, 14
    # times beyond its stability bound: the run blows up at once. Compensated at each step, it does not.
    ignored = simulate(damped.with_joint_dynamics("off"), "pinv", XARM_LINE, damped.default_configuration,
                       plant="mujoco", plant_options={**MATCHED, "damping": "urdf"})  # fmt: skip
    assert not ignored.completed and "speed of joint joint7" in ignored.stop_reason and ignored.t[-1] < 0.01


@pytest.mark.slow
def test_mujocos_frictionloss_against_the_smooth_friction_on_xarm7():
    # MuJoCo's frictionloss holds a joint at rest against up to F of demanded torque; the smooth model fades
    # below v_s. On this line from rest the two move xarm7's tip apart by 46 mm in 0.5 s (measured), which the
    # tolerance allows with some room, and no closer than 10 mm, so that a plant without friction would show.
    robot = torqueopt.load_robot("xarm7", joint_dynamics="urdf")
    reference = simulate(robot, "pinv", XARM_LINE, robot.default_configuration)
    run = simulate(robot, "pinv", XARM_LINE, robot.default_configuration, plant="mujoco", plant_options=MATCHED)
    assert reference.completed and run.completed and reference.max_tip_error < 2e-3
    assert 0.01 < np.abs(run.x - reference.x).max() < 0.06
    assert np.abs(run.joint_angles - reference.joint_angles).max() < 0.2

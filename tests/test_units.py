"""A prismatic joint is reported in N, m, m/s and m/s², a revolute one in N·m, rad, rad/s and rad/s²: in the run's
table, its messages, its files and its plots."""

from __future__ import annotations

import json

import numpy as np
import pinocchio as pin
import pytest

import torqueopt
from torqueopt.cli import main
from torqueopt.io import sidecar_path
from torqueopt.units import joint_kind, joint_unit, shared_unit

#: A planar arm of a revolute shoulder, a prismatic link (sliding along the link, 0 to 0.4 m) and a revolute wrist.
SLIDER_ARM = """<robot name="slider3">
  <link name="base"/>
  <link name="upper"><inertial><origin xyz="0.25 0 0"/><mass value="2"/>
    <inertia ixx="0.01" iyy="0.04" izz="0.04" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="slide"><inertial><origin xyz="0.2 0 0"/><mass value="1"/>
    <inertia ixx="0.005" iyy="0.02" izz="0.02" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="hand"><inertial><origin xyz="0.1 0 0"/><mass value="0.5"/>
    <inertia ixx="0.001" iyy="0.002" izz="0.002" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="tip"/>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="60" velocity="5"/></joint>
  <joint name="slider" type="prismatic"><parent link="upper"/><child link="slide"/><origin xyz="0.5 0 0"/>
    <axis xyz="1 0 0"/><limit lower="0" upper="0.4" effort="80" velocity="1"/></joint>
  <joint name="wrist" type="revolute"><parent link="slide"/><child link="hand"/><origin xyz="0.4 0 0"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="20" velocity="5"/></joint>
  <joint name="tip_joint" type="fixed"><parent link="hand"/><child link="tip"/><origin xyz="0.2 0 0"/></joint>
</robot>
"""


@pytest.fixture
def slider_urdf(tmp_path):
    path = tmp_path / "slider3.urdf"
    path.write_text(SLIDER_ARM)
    return path


@pytest.mark.parametrize(
    ("joint", "kind"),
    [
        (pin.JointModelRX(), "revolute"),
        (pin.JointModelRZ(), "revolute"),
        (pin.JointModelRevoluteUnaligned(np.array([0.0, 0.6, 0.8])), "revolute"),
        (pin.JointModelRUBZ(), "continuous"),
        (pin.JointModelRevoluteUnboundedUnaligned(), "continuous"),
        (pin.JointModelPX(), "prismatic"),
        (pin.JointModelPZ(), "prismatic"),
        (pin.JointModelPrismaticUnaligned(np.array([0.0, 0.6, 0.8])), "prismatic"),
    ],
)
def test_every_one_degree_joint_of_pinocchio_gets_its_kind(joint, kind):
    assert joint_kind(joint) == kind


def test_units_of_each_kind_and_of_a_mixed_arm():
    assert [joint_unit("prismatic", q) for q in ("position", "velocity", "acceleration", "torque")] == [
        "m", "m/s", "m/s²", "N",
    ]  # fmt: skip
    assert [joint_unit("continuous", q) for q in ("position", "velocity", "acceleration", "torque")] == [
        "rad", "rad/s", "rad/s²", "N·m",
    ]  # fmt: skip
    assert joint_unit(None, "torque") == "N·m"  # a file from before kinds were recorded
    assert shared_unit(["revolute", "prismatic", "revolute"], "velocity") == "rad/s or m/s"
    assert shared_unit(["revolute", "continuous"], "torque") == "N·m"


def test_a_prismatic_run_reports_newtons_and_metres_and_its_file_keeps_the_kinds(slider_urdf, tmp_path, capsys):
    out = tmp_path / "run.csv"
    code = main(
        ["run", "--resolver", "pinv", "--robot", str(slider_urdf), "--frame", "tip", "--task", "xy", "--degrees", "--q0", "30,0.2,-60",
         "--direction", "0,1", "--accel", "0.2", "--duration", "0.3", "--out", str(out)]
    )  # fmt: skip
    printed = capsys.readouterr().out
    assert code in (0, 4), printed
    table = {line.split()[0]: line for line in printed.splitlines() if line.split()[:1] in (["shoulder"], ["slider"])}
    header = next(line for line in printed.splitlines() if line.startswith("joint"))
    assert "[N·m]" not in header and "peak |tau|" in header  # a mixed arm: the unit in every cell
    assert table["slider"].split()[2] == "N" and table["slider"].split()[4] == "N"
    assert table["shoulder"].split()[2] == "N·m" and "80.000 N" in table["slider"]
    run = torqueopt.load_result(out)
    assert run.joint_kinds == ["revolute", "prismatic", "revolute"]
    # --degrees turned the revolute joints' values only: the slider starts 0.2 m out, not 0.2° (3.5 mm).
    np.testing.assert_allclose(run.joint_angles[0], [np.radians(30.0), 0.2, np.radians(-60.0)], atol=1e-9)
    assert json.loads(sidecar_path(out).read_text())["joint_kinds"] == ["revolute", "prismatic", "revolute"]


def test_a_run_file_written_before_kinds_were_recorded_reads_as_revolute(slider_urdf, tmp_path):
    robot = torqueopt.load_robot(str(slider_urdf), frame="tip", task="xy")
    result = torqueopt.simulate(
        robot, "pinv", torqueopt.StraightLine([0.0, 0.05], duration=0.05), q0=robot.configuration([0.5, 0.2, -1.0])
    )
    out = result.to_csv(tmp_path / "run.csv")
    sidecar = sidecar_path(out)
    record = json.loads(sidecar.read_text())
    del record["joint_kinds"]
    sidecar.write_text(json.dumps(record))
    old = torqueopt.load_result(out)
    assert old.joint_kinds is None and old.joint_unit(1, "torque") == "N·m"


def test_stop_messages_and_plot_labels_name_the_prismatic_units(slider_urdf, tmp_path, monkeypatch):
    from torqueopt.stop_rules import speed_stop_reason, torque_stop_reason

    robot = torqueopt.load_robot(str(slider_urdf), frame="tip", task="xy")
    assert robot.joint_kinds == ["revolute", "prismatic", "revolute"]
    assert torque_stop_reason(robot, np.array([0.0, 9000.0, 0.0]), 100.0, 0.5) == (
        "torque of joint slider reached 9000 N, more than 100 times its limit 80 N, at t = 0.5000 s"
    )
    assert speed_stop_reason(robot, np.array([0.0, 120.0, 1.0]), 100.0, 0.5, 0.001).startswith(
        "speed of joint slider reached 120 m/s, beyond 100 m/s"
    )
    import torqueopt.plots.run as run_figure

    saved = []
    monkeypatch.setattr(run_figure, "save_figure", lambda fig, path, dpi=None: saved.append(fig) or path)
    result = torqueopt.simulate(
        robot, "pinv", torqueopt.StraightLine([0.0, 0.05], duration=0.05), q0=robot.configuration([0.5, 0.2, -1.0])
    )
    run_figure.plot_run(result, tmp_path / "fig.png")
    labels = [ax.get_ylabel() for ax in saved[0].axes]
    assert labels[:3] == ["[N·m]", "[N]", "[N·m]"] and "[rad/s or m/s]" in labels
    titles = [ax.get_title(loc="left") for ax in saved[0].axes[:3]]
    assert titles[1] == "slider (limit ±80 N)"


def test_a_bounded_resolvers_limit_message_gives_a_sliders_excess_in_m_per_s2(slider_urdf):
    from torqueopt.resolvers.bounded.joint_limits import AccelerationBounds, JointLimits

    robot = torqueopt.load_robot(str(slider_urdf), frame="tip", task="xy")
    limits = JointLimits(robot)
    rows = limits.count
    bounds = AccelerationBounds(np.full(rows, -1.0), np.full(rows, 1.0), np.zeros(rows), np.zeros(rows), np.ones(rows))
    found = limits.exceeded(bounds, np.array([0.0, 3.0, 5.0]))
    assert found == [
        "position limit (upper) of joint slider by 2 m/s²",
        "position limit (upper) of joint wrist by 4 rad/s²",
    ]


def test_an_atlas_of_a_slider_arm_labels_its_torques_and_whip_speeds_by_kind():
    pytest.importorskip("plotly")  # the explorer's figures; the core install has no atlas extra
    from torqueopt.atlas.explorer import path_figures
    from torqueopt.atlas.report import _speed_unit

    names = ["shoulder", "slider", "wrist"]
    kinds = ["revolute", "prismatic", "revolute"]
    run = {"t": np.zeros(2), "tau": np.zeros((2, 3)), "arm": np.zeros((2, 2)), "start_arm": np.zeros((2, 2)),
           "arm_time": 0.0}  # fmt: skip
    robot = {"joint_names": names, "torque_limit": [1.0, 1.0, 1.0], "joint_kinds": kinds}
    assert "[N·m or N]" in path_figures(0, {"pinv": run}, robot)["torque"]["layout"]["title"]["text"]
    assert (
        "[N·m]" in path_figures(0, {"pinv": run}, {**robot, "joint_kinds": None})["torque"]["layout"]["title"]["text"]
    )

    config = {"joint_names": names, "joint_kinds": kinds}
    assert _speed_unit(["slider", "slider"], config) == "m/s"
    assert _speed_unit(["wrist"], config) == "rad/s"
    assert _speed_unit(["wrist", "slider"], config) == "rad/s or m/s"
    assert _speed_unit(["slider"], {"joint_names": names}) == "rad/s"  # an atlas of a revolute arm: no kinds kept

"""Playback of a run of any URDF: the run's files find its robot again, and links whose meshes are missing (or
a URDF with no visuals) are drawn as the boxes of their inertia, held to the box a link's inertia came from."""

import hashlib
import json
import shutil
import warnings

import numpy as np
import pinocchio as pin
import pytest

import torqueopt
from torqueopt import viewer
from torqueopt.cli import main
from torqueopt.errors import RobotNotFound, TorqueoptWarning
from torqueopt.run_robot import file_sha256, robot_of_run
from torqueopt.viewer.stand_ins import THINNEST, equivalent_box, link_inertia

from .test_viewer import page_commands

#: The links of a 4-joint arm with a prismatic joint: (link, joint type, axis, joint origin, mass [kg],
#: sides (a, b, c) [m] of the solid box whose inertia the link has, the inertia's rpy in the link frame).
LINKS = [
    ("link1", "revolute", "0 0 1", "0 0 0.1", 3.0, (0.10, 0.12, 0.30), (0.0, 0.0, 0.0)),
    ("link2", "revolute", "0 1 0", "0 0 0.3", 2.5, (0.40, 0.08, 0.10), (0.3, 0.2, 0.1)),
    ("link3", "prismatic", "1 0 0", "0.4 0 0", 1.5, (0.35, 0.06, 0.07), (0.0, 0.0, 0.0)),
    ("link4", "revolute", "0 1 0", "0.35 0 0", 1.0, (0.25, 0.05, 0.09), (0.1, -0.2, 0.4)),
    ("tool", "fixed", "1 0 0", "0.25 0 0", 0.4, (0.05, 0.06, 0.12), (0.0, 0.5, 0.0)),
]
#: The run's arguments after --robot: the frame must be given, the arm has two end links (tip and camera).
RUN = ["--frame", "tip", "--resolver", "null-space", "--q0", "0.1,0.5,0.1,-0.8", "--direction", "0,0.05,0.05",
       "--duration", "0.05"]  # fmt: skip


def box_moments(mass, a, b, c):
    """Principal moments of a solid box of sides a, b, c about its centre, along its edges [kg·m²]."""
    return np.array([b * b + c * c, a * a + c * c, a * a + b * b]) * mass / 12


def arm_urdf(visuals: bool, point_masses: bool = False) -> str:
    """The arm, each link's <inertial> that of its box, turned by its rpy (zero inertia for ``point_masses``);
    meshes no file holds when ``visuals``."""
    parts = ['<robot name="weird4">', '<link name="base"/>']
    parent = "base"
    for name, kind, axis, xyz, mass, sides, rpy in LINKS:
        ixx, iyy, izz = (0.0, 0.0, 0.0) if point_masses else box_moments(mass, *sides).tolist()
        mesh = f'<mesh filename="package://weird4/meshes/{name}.stl"/>'
        visual = f'<visual><origin xyz="{sides[0] / 2} 0 0"/><geometry>{mesh}</geometry></visual>' if visuals else ""
        inertial = (
            f'<inertial><origin xyz="{sides[0] / 2!r} 0 0" rpy="{" ".join(map(repr, rpy))}"/><mass value="{mass}"/>'
            f'<inertia ixx="{ixx!r}" ixy="0" ixz="0" iyy="{iyy!r}" iyz="0" izz="{izz!r}"/></inertial>'
        )
        limit = "" if kind == "fixed" else (
            f'<axis xyz="{axis}"/><limit lower="{-0.1 if kind == "prismatic" else -3}" upper="{0.3 if kind == "prismatic" else 3}" '
            'effort="200" velocity="5"/>'
        )  # fmt: skip
        parts.append(f'<link name="{name}">{inertial}{visual}</link>')
        parts.append(
            f'<joint name="j_{name}" type="{kind}"><parent link="{parent}"/><child link="{name}"/>'
            f'<origin xyz="{xyz}"/>{limit}</joint>'
        )
        parent = name
    parts.append('<link name="tip"/><joint name="j_tip" type="fixed"><parent link="tool"/><child link="tip"/>'
                 '<origin xyz="0.05 0 0"/></joint>')  # fmt: skip
    parts.append('<link name="camera"/><joint name="j_camera" type="fixed"><parent link="link2"/>'
                 '<child link="camera"/><origin xyz="0.2 0 0.05"/></joint>')  # fmt: skip
    return "\n".join([*parts, "</robot>"])


@pytest.fixture(scope="module")
def arm_urdfs(tmp_path_factory):
    """A folder with weird4.urdf (every mesh missing), bare4.urdf (no visuals) and points4.urdf (no visuals, point
    masses)."""
    folder = tmp_path_factory.mktemp("arm")
    for stem, visuals in (("weird4", True), ("bare4", False)):
        (folder / f"{stem}.urdf").write_text(arm_urdf(visuals))
    (folder / "points4.urdf").write_text(arm_urdf(False, point_masses=True))
    return folder


@pytest.fixture(scope="module")
def arm_files(arm_urdfs):
    """The URDFs' folder with a run of each by ``torqueopt run --out``; bare4's with its prismatic joint locked."""
    folder = arm_urdfs
    assert main(["run", "--robot", str(folder / "weird4.urdf"), *RUN, "--out", str(folder / "weird4.csv")]) == 0
    locked = ["--frame", "tip", "--lock", "j_link3", "--resolver", "pinv", "--q0", "0.1,0.5,-0.8",
              "--direction", "0,0.05,0.05", "--duration", "0.05"]  # fmt: skip
    assert main(["run", "--robot", str(folder / "bare4.urdf"), *locked, "--out", str(folder / "bare4.csv")]) == 0
    return folder


def play(run, tmp_path, capsys, *options):
    """``torqueopt play RUN --html`` with ``options``: (exit code, stderr lines, the page's commands or None)."""
    page = tmp_path / "page.html"
    code = main(["play", str(run), "--html", str(page), "--fps", "5", *options])
    lines = capsys.readouterr().err.strip().splitlines()
    return code, lines, page_commands(page.read_text()) if code == 0 else None


def boxes_drawn(commands) -> dict[str, list[float]]:
    """Side lengths of the boxes a page draws, by the node's name."""
    return {
        command["path"].rsplit("/", 1)[-1]: [command["object"]["geometries"][0][key] for key in ("width", "height", "depth")]
        for command in commands
        if command["type"] == "set_object" and command["object"]["geometries"][0]["type"] == "BoxGeometry"
    }  # fmt: skip


@pytest.mark.slow
def test_a_run_of_a_urdf_with_missing_meshes_plays_with_no_robot_given(arm_files, tmp_path, capsys):
    sidecar = json.loads((arm_files / "weird4.csv.json").read_text())
    urdf = arm_files / "weird4.urdf"
    assert sidecar["robot"] == "weird4" and sidecar["frame"] == "tip"
    assert sidecar["robot_source"]["urdf"] == str(urdf.resolve())
    assert sidecar["robot_source"]["sha256"] == hashlib.sha256(urdf.read_bytes()).hexdigest()
    code, lines, commands = play(arm_files / "weird4.csv", tmp_path, capsys)
    assert code == 0
    assert lines == [
        "torqueopt play: note: 5 meshes of 'weird4.urdf' not found (package://weird4/meshes/link1.stl, "
        "package://weird4/meshes/link2.stl, package://weird4/meshes/link3.stl and 2 more): drawn as the boxes of "
        "their links' inertia"
    ]
    assert sorted(boxes_drawn(commands)) == [f"{name}_inertia_box" for name, *_ in sorted(LINKS)]


@pytest.mark.slow
def test_a_urdf_with_no_visuals_plays_as_the_boxes_of_its_links(arm_files, tmp_path, capsys):
    """The run locked j_link3 (--lock), which the sidecar records: play locks it again, so the robot has the run's
    three joints."""
    assert json.loads((arm_files / "bare4.csv.json").read_text())["joint_names"] == ["j_link1", "j_link2", "j_link4"]
    code, lines, commands = play(arm_files / "bare4.csv", tmp_path, capsys)
    assert code == 0
    assert lines == ["torqueopt play: note: URDF 'bare4.urdf' has no visuals: its links are drawn as the boxes of their "
                     "inertia, and base (no rotational inertia) as rods to its child joints"]  # fmt: skip
    drawn = boxes_drawn(commands)
    # Massless links (base, tip, camera) are not drawn; each other link is its box, whatever its order of sides.
    assert sorted(drawn) == [f"{name}_inertia_box" for name, *_ in sorted(LINKS)]
    for name, _, _, _, _, sides, _ in LINKS:
        np.testing.assert_allclose(sorted(drawn[f"{name}_inertia_box"]), sorted(sides), rtol=1e-9)


@pytest.mark.slow
def test_a_changed_urdf_plays_with_a_note_and_a_gone_one_is_one_line_exit_2(arm_files, tmp_path, capsys):
    moved = tmp_path / "run"
    moved.mkdir()
    urdf = moved / "weird4.urdf"
    shutil.copy(arm_files / "weird4.urdf", urdf)
    assert main(["run", "--robot", str(urdf), *RUN, "--out", str(moved / "run.csv")]) == 0
    recorded = json.loads((moved / "run.csv.json").read_text())["robot_source"]["sha256"]
    capsys.readouterr()

    urdf.write_text(urdf.read_text() + "<!-- edited after the run -->\n")
    code, lines, _ = play(moved / "run.csv", tmp_path, capsys)
    assert code == 0
    assert lines[0] == (
        f"torqueopt play: note: URDF '{urdf}' has changed since the run was made (SHA-256 {recorded[:12]}… then, "
        f"{file_sha256(urdf)[:12]}… now): loading the file as it is now"
    )

    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    urdf.rename(elsewhere / "weird4.urdf")
    code, lines, _ = play(moved / "run.csv", tmp_path, capsys)
    assert code == 2
    assert lines == [
        f"torqueopt play: error: the run's URDF '{urdf}' does not exist any more; give the robot's URDF with "
        "--robot FILE"
    ]
    # --robot names the file where it is now; the run's frame still applies (this arm has two end links, so
    # without it the URDF alone names no frame).
    code, lines, commands = play(moved / "run.csv", tmp_path, capsys, "--robot", str(elsewhere / "weird4.urdf"))
    assert code == 0 and len(boxes_drawn(commands)) == len(LINKS)
    assert "has changed since the run" in lines[0]  # the edit is still there


@pytest.mark.slow
def test_a_sidecar_of_before_plays_as_it_did_and_with_robot_file_keeps_its_frame(arm_files, tmp_path, capsys):
    old = tmp_path / "old.csv"
    shutil.copy(arm_files / "weird4.csv", old)
    sidecar = json.loads((arm_files / "weird4.csv.json").read_text())
    del sidecar["robot_source"]
    (tmp_path / "old.csv.json").write_text(json.dumps(sidecar))
    code, lines, _ = play(old, tmp_path, capsys)
    assert code == 2 and lines[0].startswith("torqueopt play: error: unknown robot 'weird4'")
    code, lines, commands = play(old, tmp_path, capsys, "--robot", str(arm_files / "weird4.urdf"))
    assert code == 0 and len(boxes_drawn(commands)) == len(LINKS)


@pytest.mark.slow
def test_the_stick_figures_of_a_run_of_a_urdf_find_it_too(arm_files, tmp_path, capsys, saved_figures):
    """``plot RUN --stick-figures`` said "unknown robot 'weird4'" too. The arm drawn is the run's: in each panel
    the tip of the arm (forward kinematics of the robot found again) is where the run's x column puts it, the end
    of the tip path so far (the frame 'camera', say, would be elsewhere)."""
    plot = ["plot", str(arm_files / "weird4.csv"), "--out", str(tmp_path / "f.png"), "--stick-figures", "--snapshots"]
    assert main([*plot, "2", "--ellipse", "none"]) == 0
    panels = [ax for ax in saved_figures[-1].axes if any(line.get_label() == "tip" for line in ax.lines)]
    assert len(panels) == 2
    for ax in panels:
        lines = {line.get_label(): line.get_xydata() for line in ax.lines}
        np.testing.assert_allclose(lines["tip"][0], lines["tip path so far"][-1], atol=1e-8)


# -- the boxes: held to the box each link's inertia was written from ----------------------------------------


@pytest.fixture(scope="module")
def bare_arm(arm_urdfs):
    return torqueopt.load_robot(arm_urdfs / "bare4.urdf", frame="tip")


def rotation(rpy):
    return pin.rpy.rpyToMatrix(*rpy)


@pytest.mark.parametrize("link", [name for name, *_ in LINKS])
def test_each_box_has_the_links_mass_moments_axes_and_centre(bare_arm, link):
    """The box of a link, as a solid of the link's mass (pin.Inertia.FromBox), has the link's inertia: the moments
    and axes of the URDF's inertia, which is that of the box of sides (a, b, c) turned by rpy. link4 holds its
    fixed tool in Pinocchio's body inertia, and tool is Pinocchio's fixed-joint frame inertia."""
    _, _, _, _, mass, sides, rpy = next(row for row in LINKS if row[0] == link)
    model = bare_arm.full_model
    inertia = link_inertia(model, model.getFrameId(link, pin.FrameType.BODY))
    box_sides, placement = equivalent_box(inertia)
    assert inertia.mass == pytest.approx(mass, rel=1e-12)
    np.testing.assert_allclose(sorted(box_sides), sorted(sides), rtol=1e-9)
    box = pin.Inertia.FromBox(mass, *box_sides)
    # Turned to the link's frame, the box's inertia about its centre is the URDF's, R diag(I) Rᵀ.
    urdf_inertia = rotation(rpy) @ np.diag(box_moments(mass, *sides)) @ rotation(rpy).T
    np.testing.assert_allclose(placement.rotation @ box.inertia @ placement.rotation.T, urdf_inertia, atol=1e-12)
    np.testing.assert_allclose(placement.translation, [sides[0] / 2, 0, 0], atol=1e-12)


def test_a_rod_or_a_plate_is_drawn_with_a_tenth_of_its_length_as_thickness():
    # planar3's link: a thin rod of 10 kg and 1 m along x, no inertia about its axis.
    rod = pin.Inertia(10.0, np.array([0.5, 0, 0]), np.diag([0.0, 10 / 12, 10 / 12]))
    sides, placement = equivalent_box(rod)
    np.testing.assert_allclose(sorted(sides), [THINNEST, THINNEST, 1.0], rtol=1e-12)
    np.testing.assert_allclose(placement.translation, [0.5, 0, 0])
    assert equivalent_box(pin.Inertia.Zero()) is None


def test_the_playback_of_the_bare_arm_places_each_box_at_its_links_centre_of_mass(bare_arm):
    angles = np.array([0.1, 0.5, 0.1, -0.8])
    q = bare_arm.configuration(angles)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model, geometry = viewer.visual_model(bare_arm)
    assert [str(w.message) for w in caught if w.category is TorqueoptWarning] == [
        "URDF 'bare4.urdf' has no visuals: its links are drawn as the boxes of their inertia, and base (no rotational inertia) as "
        "rods to its child joints"
    ]
    data, geometry_data = model.createData(), geometry.createData()
    pin.forwardKinematics(model, data, q)
    pin.updateGeometryPlacements(model, data, geometry, geometry_data)
    dynamic = bare_arm.model.createData()
    pin.forwardKinematics(bare_arm.model, dynamic, q)
    pin.updateFramePlacements(bare_arm.model, dynamic)
    for name, _, _, _, _, sides, _ in LINKS:
        box = geometry_data.oMg[geometry.getGeometryId(f"{name}_inertia_box")]
        link = dynamic.oMf[bare_arm.model.getFrameId(name, pin.FrameType.BODY)]
        np.testing.assert_allclose(box.translation, link.act(np.array([sides[0] / 2, 0, 0])), atol=1e-12)


def test_a_chain_of_point_masses_is_drawn_as_rods_from_joint_to_joint(arm_urdfs):
    """Each rod runs from a link's origin to one of its child joints: its ends are where the dynamic model puts
    the two links' frames, at a bent configuration (the prismatic joint at 0, where its link's frame is its
    joint's origin)."""
    robot = torqueopt.load_robot(arm_urdfs / "points4.urdf", frame="tip")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model, geometry = viewer.visual_model(robot)
    assert [str(w.message) for w in caught if w.category is TorqueoptWarning] == [
        "URDF 'points4.urdf' has no visuals: its links are drawn as the boxes of their inertia, and base, link1, "
        "link2, link3, link4, tool (no rotational inertia) as rods to their child joints"
    ]
    q = robot.configuration(np.array([0.3, -0.7, 0.0, 1.1]))
    data, geometry_data = model.createData(), geometry.createData()
    pin.forwardKinematics(model, data, q)
    pin.updateGeometryPlacements(model, data, geometry, geometry_data)
    dynamic = robot.model.createData()
    pin.framesForwardKinematics(robot.model, dynamic, q)

    def origin(link):
        return dynamic.oMf[robot.model.getFrameId(link, pin.FrameType.BODY)].translation

    #: (link, child link) of each joint of the arm, in the order of the URDF's joints under each link.
    segments = [("base", "link1"), ("link1", "link2"), ("link2", "link3"), ("link2", "camera"), ("link3", "link4"),
                ("link4", "tool"), ("tool", "tip")]  # fmt: skip
    rods = [g for g in geometry.geometryObjects if "_rod_" in g.name]
    assert len(rods) == len(segments)
    for link, child in segments:
        ends = [origin(link), origin(child)]
        found = False
        for rod in rods:
            if not rod.name.startswith(f"{link}_rod_"):
                continue
            placement = geometry_data.oMg[geometry.getGeometryId(rod.name)]
            half = rod.geometry.halfLength * placement.rotation[:, 2]
            drawn = [placement.translation - half, placement.translation + half]
            found |= all(np.allclose(a, b, atol=1e-12) for a, b in zip(drawn, ends))
        assert found, f"no rod from {link} to {child}"


# -- the robot of a run, through the API -----------------------------------------------------------------------


def test_a_catalogue_robots_run_records_its_file_and_loads_by_name(planar3, tmp_path):
    result = torqueopt.simulate(
        planar3, "pinv", torqueopt.StraightLine([0.1, 0.1], duration=0.01), [-0.78, 2.35, -2.35]
    )
    record = result.robot_source
    assert record["urdf"] == str(planar3.source.urdf.resolve())
    assert record["sha256"] == file_sha256(planar3.source.urdf)
    assert record["locked_joints"] == [] and record["locked_configuration"] == list(planar3.locked_configuration)
    from torqueopt.batch import simulate_batch

    lines = [torqueopt.StraightLine(direction, duration=0.01) for direction in ([0.1, 0.1], [-0.1, 0.1])]
    batch = simulate_batch(planar3, "pinv", lines, [[-0.78, 2.35, -2.35]] * 2)
    assert [movement.robot_source for movement in batch] == [record, record]
    back = torqueopt.load_result(result.to_csv(tmp_path / "run.npz"))
    assert back.robot_source == record
    robot = robot_of_run(back)
    assert robot.source.vetted and robot.source.name == "planar3" and robot.joint_names == planar3.joint_names
    # Installed elsewhere since (a new environment): the catalogue's file of the same bytes serves.
    back.robot_source = {**record, "urdf": str(tmp_path / "gone" / "planar3.urdf")}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert robot_of_run(back).source.urdf == planar3.source.urdf
    back.robot_source = {**back.robot_source, "sha256": "0" * 64}
    with pytest.raises(RobotNotFound, match=r"the run's URDF '.*gone/planar3.urdf' does not exist any more"):
        robot_of_run(back)


@pytest.mark.slow
@pytest.mark.browser
def test_the_screenshot_of_the_page_shows_the_boxes(chromium, arm_files, tmp_path, capsys):
    """The HTML page and its screenshot draw the same stand-ins as the player: grey-blue boxes on the grey
    background (a page without them has no such pixels, tests/test_viewer.py's blank page)."""
    import matplotlib.image

    page = tmp_path / "bare4.html"
    assert main(["play", str(arm_files / "bare4.csv"), "--html", str(page), "--fps", "5"]) == 0
    image = matplotlib.image.imread(viewer.screenshot_html(page, tmp_path / "bare4.png", width=800, height=500))
    red, blue = image[:, :, 0], image[:, :, 2]
    assert ((blue - red > 0.08) & (blue > 0.3)).sum() > 3000, "no box drawn"


@pytest.mark.slow
def test_an_optimum_of_a_user_urdf_plays_with_no_robot_given(tmp_path, capsys):
    """``optimize --out`` records the robot as ``run --out`` does: its file plays without ``--robot``."""
    urdf = tmp_path / "my3.urdf"
    shutil.copy(torqueopt.catalog.find_robot("planar3").urdf, urdf)
    out = tmp_path / "opt.csv"
    arguments = ["optimize", "--robot", str(urdf), "--frame", "tip", "--task", "xy", "--direction", "1,1",
                 "--q0=-0.7853981634,2.3561944902,-2.3561944902", "--duration", "0.3", "--out", str(out)]  # fmt: skip
    assert main(arguments) == 0
    assert json.loads(out.with_name("opt.csv.json").read_text())["robot_source"]["sha256"] == file_sha256(urdf)
    capsys.readouterr()
    assert main(["play", str(out), "--html", str(tmp_path / "opt.html")]) == 0
    assert capsys.readouterr().err == ""

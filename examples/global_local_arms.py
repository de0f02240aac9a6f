"""Local against global on two 7-joint arms: the whole-movement optimum, joint limits in it, beside the local resolvers.

The paper's arm answered its closing question (docs/discussion/local-global.md): local torque optimisation
whips on long movements, the whole-movement optimum does not. This script asks it again on panda and xarm7,
whose URDFs give joint position and velocity limits: ``torqueopt.optimize`` with the limits in the
optimisation (``joint_limits=True``: ``torqueopt optimize --joint-limits``), ending at rest and ending
free, against ``pinv``, the remedy as
``torqueopt tune`` chose it for the arm (``damped-null-space``; docs/atlas/tune-ARM.md), ``bounded-torque``
(torque bounds and joint limits, its defaults) and ``energy-bounded-torque`` (its defaults, and the arm's
setting where one was measured), all on the
same 1 ms grid, by the same cost ∫‖τ‖² dt and the same judgement (the whiplash detector, the torque and
joint limits, the tip's distance from its path; a joint limit counts as passed beyond 1e-6 of it, since
the optimum rides its bounds and its replay passes them by about 1e-7).

The movements, per arm, from its default configuration: the standard line along +y at the atlas's
acceleration for the arm (√2 m/s² x reach / 3 m, torqueopt.atlas.population.default_accel) over three
durations, and one circle of the same duration as the longest line, in the horizontal plane through the
start with its centre towards the arm's vertical axis, whose circumference is that line's length.

Run: python examples/global_local_arms.py [--robots panda,xarm7] [--durations 0.5,1,2] [--out global-local-arms]
(writes global-local-arms.md and global-local-arms.png into --out, and rows.json: run again into the same
folder, it computes only the rows it lacks; about 2 core-minutes per arm)
"""

import argparse
import json
import math
import time
from functools import partial
from pathlib import Path

import numpy as np

import torqueopt
from torqueopt.atlas.global_optimum import replay_result
from torqueopt.atlas.population import arm_reach, default_accel
from torqueopt.errors import InvalidInput
from torqueopt.optimal import run_cost
from torqueopt.tune import tuned_options
from torqueopt.whiplash import DEFAULT_PATH_TOLERANCE, detect_whiplash

#: Where ``torqueopt tune`` wrote its choice for each arm (docs/atlas/tune-ARM.md has the evidence).
TUNED = Path(__file__).resolve().parent.parent / "docs" / "atlas"
#: The whole-movement optima, with the URDF's joint limits: (label, end, IPOPT iterations per Hessian tried).
#: At rest at T is the movement a robot makes; end free (``--end-free``) lets every local run be a candidate
#: (its cost a lower bound of theirs, once converged), but on these arms IPOPT converges slowly there
#: (panda's 0.5 s line: "failed" after 315 iterations), so it is bounded and not run by default. The 2 s
#: movements stopped at 500 iterations per Hessian (1000 in all) a long way from converged, hence 1500.
REST, FREE = ("global, joint limits, end at rest", "rest", 1500), ("global, joint limits, end free", "free", 300)
#: ``energy-bounded-torque``'s setting per arm where one was measured (docs/guide/energy-bounded-torque.md,
#: "Settings per arm": panda's is the nearest to qualifying in its tune); other arms run its defaults.
ENERGY_SETTINGS = {"panda": {"energy_limit": 0.01, "joint_acceleration_limit": 10.0}}

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
parser.add_argument("--robots", default="panda,xarm7", help="comma-separated arms (default panda,xarm7)")
parser.add_argument("--durations", default="0.5,1,2", help="durations of the line [s] (default 0.5,1,2)")
parser.add_argument("--no-circle", action="store_true", help="the lines only")
parser.add_argument("--end-free", action="store_true", help="also the optimum whose end is free (slow here)")
parser.add_argument("--out", default="global-local-arms", help="output folder (default global-local-arms)")
arguments = parser.parse_args()
GLOBALS = (REST, FREE) if arguments.end_free else (REST,)
durations = [float(text) for text in arguments.durations.split(",")]
out = Path(arguments.out)


#: A joint limit counts as passed beyond this fraction of it: the optimum rides its bounds (IPOPT's
#: tolerance on the 5 ms grid), and its open-loop replay on the 1 ms grid passes them by about 1e-7.
JOINT_LIMIT_TOLERANCE = 1e-6


def joint_limits(run) -> tuple[str | None, str | None]:
    """(the first joint limit passed, in words, or None; the joints that reach a limit within the tolerance)."""
    angles, speeds = run.joint_angles, np.abs(run.v)
    lower, upper, fastest = run.position_lower, run.position_upper, run.velocity_limit
    span = np.where(np.isfinite(upper - lower), upper - lower, 1.0)
    margin = JOINT_LIMIT_TOLERANCE * span
    over_position = (angles < lower - margin) | (angles > upper + margin)
    over_speed = speeds > fastest * (1 + JOINT_LIMIT_TOLERANCE)
    at_speed = (speeds >= fastest * (1 - JOINT_LIMIT_TOLERANCE)).any(axis=0)
    at_position = ((angles <= lower + margin) | (angles >= upper - margin)).any(axis=0)
    riding = [run.joint_names[j] for j in np.flatnonzero(at_speed | at_position)]
    if over_position.any():
        row, joint = np.argwhere(over_position)[0]
        bound = upper[joint] if angles[row, joint] > upper[joint] else lower[joint]
        name = run.joint_names[joint]
        return (
            f"position limit of {name} at {run.t[row]:.3f} s ({angles[row, joint]:.4g} rad, limit {bound:.4g})",
            riding,
        )
    if over_speed.any():
        row, joint = np.argwhere(over_speed)[0]
        worst = float(np.max(speeds[:, joint]) / fastest[joint])
        return f"velocity limit of {run.joint_names[joint]} at {run.t[row]:.3f} s (up to {worst:.6f} x it)", riding
    return None, riding


def judge(run, robot) -> str:
    """'problem-free', or the first problem: whips, over a torque limit, a joint limit, off its path, stopped."""
    if not run.completed:
        return f"stopped at {run.stop_time:.3f} s"
    report = detect_whiplash(run)
    if report.unstable:
        return f"unstable from {report.time:.3f} s"
    if np.nanmax(run.peak_torque_ratio) > 1.0:
        return f"over a torque limit ({np.nanmax(run.peak_torque_ratio):.2f})"
    passed, riding = joint_limits(run)
    if passed:
        return passed
    if run.max_tip_error > DEFAULT_PATH_TOLERANCE:
        return f"off its path ({run.max_tip_error * 1e3:.1f} mm)"
    return "problem-free" + (f" (at a joint limit: {', '.join(riding)})" if riding else "")


def tuned_setting(name: str) -> dict | None:
    """The damped-null-space options the arm's tune chose, or None (no tune, or no setting qualified)."""
    path = TUNED / f"tune-{name}.json"
    if not path.is_file():
        return None
    try:
        resolver, options = tuned_options(path)
    except InvalidInput:  # the tune chose no setting
        return None
    return options if resolver == "damped-null-space" else None


def movements(robot):
    """(name, trajectory) per movement: the lines, then the circle."""
    accel = default_accel(arm_reach(robot)[1])
    found = [(f"line {d:g} s", torqueopt.StraightLine([0.0, 1.0, 0.0], accel=accel, duration=d)) for d in durations]
    if not arguments.no_circle:
        longest = max(durations)
        radius = accel * longest**2 / 4 / (2 * math.pi)  # circumference = the longest line's length
        found.append((f"circle {longest:g} s", torqueopt.Circle(radius, longest)))
    return accel, found


# Each row is kept in DIR/rows.json as it is computed: run again into the same folder, the script computes
# only the rows it lacks (a remedy tuned since, another arm), and redraws the table and the figure.
out.mkdir(parents=True, exist_ok=True)
cache_file = out / "rows.json"
cache = json.loads(cache_file.read_text(encoding="utf-8")) if cache_file.is_file() else {}


def row_for(name, movement, label, compute):
    """The cached row of (arm, movement, method), or ``compute()``'s, cached."""
    key = f"{name} | {movement} | {label}"
    if key not in cache:
        cache[key] = {"robot": name, "movement": movement, "method": label, **compute()}
        temporary = cache_file.with_suffix(".part")
        temporary.write_text(json.dumps(cache, indent=1), encoding="utf-8")
        temporary.replace(cache_file)  # never a half-written cache
    return dict(cache[key])


def global_row(robot, trajectory, q0, end, iterations):
    started = time.process_time()
    optimum = torqueopt.optimize(robot, trajectory, q0, end=end, joint_limits=True, max_iterations=iterations)
    seconds = time.process_time() - started
    replay = replay_result(robot, optimum)  # the optimal torques played back open loop, as a robot would
    return {
        "cost": run_cost(replay, robot), "peak": float(np.nanmax(replay.peak_torque_ratio)),
        "verdict": judge(replay, robot),
        "note": f"IPOPT {optimum.status}, {optimum.iterations} iterations, {seconds:.0f} s CPU; replay "
                f"{optimum.replay_tip_error * 1e3:.3f} mm off the path",
    }  # fmt: skip


def local_row(robot, resolver, trajectory, q0):
    run = torqueopt.simulate(robot, resolver, trajectory, q0)
    return {
        "cost": run_cost(run, robot), "peak": float(np.nanmax(run.peak_torque_ratio)),
        "verdict": judge(run, robot), "note": "",
    }  # fmt: skip


rows = []
for name in arguments.robots.split(","):
    robot = torqueopt.load_robot(name)
    q0 = robot.default_configuration
    accel, paths = movements(robot)
    tuned = tuned_setting(name)
    remedy = torqueopt.get_resolver("damped-null-space", **(tuned or {}))
    remedy_label = f"{remedy.label} (tuned)" if tuned else "damped-null-space (defaults: none qualified)"
    local = [
        ("pinv", torqueopt.get_resolver("pinv")),
        (remedy_label, remedy),
        ("bounded-torque", torqueopt.get_resolver("bounded-torque")),
        ("energy-bounded-torque", torqueopt.get_resolver("energy-bounded-torque")),
    ]
    if name in ENERGY_SETTINGS:
        energy = torqueopt.get_resolver("energy-bounded-torque", **ENERGY_SETTINGS[name])
        local.append((f"{energy.label} (the arm's setting)", energy))
    for movement, trajectory in paths:
        print(f"{name}, {movement} (a = {accel:.3f} m/s²):", flush=True)
        for label, end, iterations in GLOBALS:
            rows.append(row_for(name, movement, label, partial(global_row, robot, trajectory, q0, end, iterations)))
        for label, resolver in local:
            rows.append(row_for(name, movement, label, partial(local_row, robot, resolver, trajectory, q0)))
        for row in rows[-len(GLOBALS) - len(local) :]:
            print(f"  {row['method']:<52} cost {row['cost']:12.2f}  peak {row['peak']:6.2f}  {row['verdict']}")

for row in rows:  # against the rest-to-rest optimum, the first global row of the movement
    row["vs_global"] = row["cost"] / next(
        r["cost"] for r in rows if r["robot"] == row["robot"] and r["movement"] == row["movement"]
    )

lines = [
    "| arm | movement | method | ∫‖τ‖² dt [N²·m²·s] | vs global (rest) | peak |τ|/limit | verdict |",
    "|---|---|---|---|---|---|---|",
]
for row in rows:
    note = f" ({row['note']})" if row["note"] else ""
    lines.append(
        f"| {row['robot']} | {row['movement']} | {row['method']} | {row['cost']:.1f} | {row['vs_global']:.3f} | "
        f"{row['peak']:.2f} | {row['verdict']}{note} |"
    )
(out / "global-local-arms.md").write_text("\n".join(lines) + "\n", encoding="utf-8")

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

robots = list(dict.fromkeys(row["robot"] for row in rows))
figure, axes = plt.subplots(1, len(robots), figsize=(6.0 * len(robots), 4.2), squeeze=False)
markers = {"pinv": "o", "bounded-torque": "s", "energy-bounded-torque": "^", FREE[0]: "*"}
for axis, name in zip(axes[0], robots):
    mine = [row for row in rows if row["robot"] == name]
    names = list(dict.fromkeys(row["movement"] for row in mine))
    methods = [m for m in dict.fromkeys(row["method"] for row in mine) if m != GLOBALS[0][0]]
    for offset, method in enumerate(methods):
        for index, movement in enumerate(names):
            row = next(r for r in mine if r["method"] == method and r["movement"] == movement)
            free = row["verdict"].startswith("problem-free")
            axis.plot(
                index + 0.12 * (offset - 2), row["vs_global"], markers.get(method, "D"), color=f"C{offset}",
                markerfacecolor=f"C{offset}" if free else "none", markersize=8,
                label=method if index == 0 else None,
            )  # fmt: skip
    axis.axhline(1.0, color="black", linewidth=0.8, label=GLOBALS[0][0])
    axis.set_yscale("log")
    axis.set_xticks(range(len(names)), names)
    axis.set_ylabel("∫‖τ‖² dt over the global optimum's")
    axis.set_title(f"{name}: filled = problem-free, hollow = a problem")
    axis.legend(fontsize=7, loc="best", framealpha=0.5)
figure.tight_layout()
figure.savefig(out / "global-local-arms.png", dpi=150)
print(f"wrote {out / 'global-local-arms.md'} and {out / 'global-local-arms.png'}")

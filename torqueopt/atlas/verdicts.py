r"""Verdicts: whiplash, a path that is simply too demanding, a lost path, or stable.

Two criteria are computed for every (movement, resolver) run, and both are
kept in the results table:

The 2x-limit rule (column ``unstable``)
    :func:`torqueopt.whiplash.detect_whiplash`: unstable from the first
    sample where a joint needs more than ``limit_factor`` (default 2) times
    its torque limit; ``instability_time`` is that sample [s]. It cannot tell
    a whip from a path the arm cannot do: on a path where even ``pinv``
    needs twice the limits, every resolver fails it.

The runaway criterion (column ``runaway``)
    What the whip is, measured directly, by two figures:

    * ``torque_vs_pinv``: the run's peak :math:`|\tau|/\tau^+` over that of
      ``pinv`` on the same path. Above ``pinv_factor`` (default 2) the
      resolver needs much more torque than the plain pseudoinverse does for
      the very same tip motion: the excess is the resolver's own doing.
    * ``self_motion_energy_ratio``: the peak kinetic energy of the
      self-motion over the peak kinetic energy the tip motion itself needs,

      .. math::

          \rho = \frac{\max_t E_N(t)}{\max_t E_x(t)},\qquad
          E_x = \tfrac12\dot x^\top\Lambda\dot x,\quad
          \Lambda = (J H^{-1} J^\top)^{-1},\quad
          E_N = \tfrac12\dot q^\top H\dot q - E_x \ge 0,

      where :math:`E_x` is the least kinetic energy of any joint motion
      with the tip velocity :math:`\dot x = J\dot q`, so :math:`E_N` is the
      energy in the part of the motion that does not move the tip: the
      self-motion that builds up and whips. Above ``energy_factor`` (default
      10) the self-motion carries ten times the energy the task ever needs.
      This figure does not need ``pinv``, so it judges ``pinv`` too.

    ``runaway`` is true when either figure is above its threshold, and
    ``runaway_time`` is the first sample at which the energy ratio (running
    maximum of :math:`E_N` over that of :math:`E_x`) passes its threshold.

The verdict (column ``verdict``)
    * ``"whiplash"``: the 2x-limit rule fails after the first sample and the
      runaway criterion fires;
    * ``"too demanding"``: the 2x-limit rule fails but nothing ran away (the
      torque is what ``pinv`` needs on the path too, and the self-motion is
      small), or it fails at the very first sample, before any self-motion
      could build up: the path asks more than the arm has;
    * ``"joint limits"``: neither of those, but a joint left its URDF position
      or velocity limits at some sample (the final state included): the
      torques stayed within the 2x-limit rule, but a joint went outside its
      range or faster than its limit;
    * ``"singular"``: the run reached a singular Jacobian, the task's or an
      algorithmic one such as the extended Jacobian's (and stopped there, at
      t = 0 too), before failing the 2x-limit rule;
    * ``"lost path"``: none of the above, but the tip left its path by more than
      :data:`~torqueopt.whiplash.DEFAULT_PATH_TOLERANCE` (1 mm): a resolver under
      hard torque bounds gives up task acceleration instead of torque;
    * ``"stopped early"``: none of the above, but the run stopped before its end
      (it diverged);
    * ``"stable"``: otherwise (the runaway figures are still in the row): a run that
      left its path or stopped short is never stable;
    * ``"infeasible for every resolver"``: a ``global-optimum`` row only, under
      ``--global-bounded`` (:mod:`torqueopt.atlas.global_optimum`): the
      whole-movement solver found that no motion along the path stays within the
      torque and joint limits (its evidence in ``optimizer_evidence``). Unlike
      ``too demanding``, which says what one run needed, this says what any run
      would: the atlas reports the problem-free shares over the feasible paths
      beside the raw ones.

The thresholds 2 and 10 were read off a first look at 60 random paths of the
paper's arm (0.5 to 2 s) and the paper's three movements before the atlas
was run, not fitted to it: there, runs that pass the 2x-limit rule stay
below an energy ratio of about 9 (``weighted-null-space`` keeps a large
self-motion even on short paths: 4.4 on the paper's short one), and the
null-space runs that whip reach 10 to 100; the paper's long movement needs
14 (null-space), 83 (weighted) and 4.2 (inertia-pinv) times pinv's peak
torque.

A resolver under hard torque bounds (``bounded-torque``, ``minmax-torque``)
cannot fail the 2x-limit rule: it gives up task acceleration instead, and
the row keeps ``max_task_error`` [m/s²] and ``infeasible_steps`` beside
``max_tip_error`` [m], which show where such a resolver lost the path.

When and where a run left its joint limits: ``first_position_limit_violation``
and ``first_velocity_limit_violation`` [s] are the first samples outside the
URDF's position and velocity limits (NaN when the run stayed inside them),
``position_limit_joint`` and ``velocity_limit_joint`` the
joints (None when none), as :attr:`SimResult.first_position_violation
<torqueopt.SimResult.first_position_violation>` finds them. The
columns are kept for every verdict: a whip usually leaves the limits too.

Where the whip happened: at ``whip_time`` (the instability time, else the
time of the peak torque demand) the row keeps the joint nearest to aligned
(``aligned_joint``, the joint beyond the first whose wrapped angle is
nearest 0, so that its two links line up; ``aligned_angle`` [rad]) and the
fastest joint with its speed (``whip_speed_joint``, ``whip_speed`` [rad/s]).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

import numpy as np
import pinocchio as pin

from ..result import SimResult
from ..robot import Robot
from ..self_motion import self_motion
from ..settings import Settings, positive, positive_in, setting
from ..whiplash import DEFAULT_LIMIT_FACTOR, DEFAULT_PATH_TOLERANCE, detect_whiplash

#: One colour per verdict, for every figure and page of the atlas (the workspace map, the explorer).
VERDICT_COLOURS = {
    "stable": "#2ca02c",
    "whiplash": "#d62728",
    "too demanding": "#ff7f0e",
    "joint limits": "#9467bd",
    "singular": "#7f7f7f",
    "lost path": "#8c564b",
    "stopped early": "black",
    "infeasible for every resolver": "#17becf",
}

__all__ = [
    "DEFAULT_ENERGY_FACTOR",
    "DEFAULT_PINV_FACTOR",
    "INFEASIBLE",
    "VERDICTS",
    "Thresholds",
    "run_row",
    "self_motion_energy",
]

#: runaway when a run needs more than this multiple of pinv's peak torque ratio on the same path.
DEFAULT_PINV_FACTOR = 2.0
#: runaway when the self-motion's peak kinetic energy exceeds this multiple of the task's.
DEFAULT_ENERGY_FACTOR = 10.0
#: The verdict of a path on which no motion within the limits exists (a ``global-optimum`` row's, see above).
INFEASIBLE = "infeasible for every resolver"
VERDICTS = ("stable", "whiplash", "too demanding", "joint limits", "singular", "lost path", "stopped early", INFEASIBLE)
_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
_PER_JOINT_FIELDS = ("torque_upper", "torque_lower")


@dataclass(frozen=True)
class Thresholds(Settings):
    """The verdict thresholds: ``limit_factor`` (2x-limit rule), ``pinv_factor`` and ``energy_factor`` (runaway)."""

    TITLE = "verdicts (see torqueopt.atlas.verdicts)"

    limit_factor: float = setting(
        DEFAULT_LIMIT_FACTOR,
        "2x-limit rule: unstable above K x the limit (default 2)",
        check=positive_in(hint="a multiple of the torque limit, such as 2"),
        parse=positive,
        metavar="K",
    )
    pinv_factor: float = setting(
        DEFAULT_PINV_FACTOR,
        f"runaway above K x pinv's peak torque on the path (default {DEFAULT_PINV_FACTOR:g})",
        check=positive_in(hint="a multiple of pinv's torque, such as 2"),
        parse=positive,
        metavar="K",
    )
    energy_factor: float = setting(
        DEFAULT_ENERGY_FACTOR,
        f"runaway when self-motion energy exceeds K x the task's (default {DEFAULT_ENERGY_FACTOR:g})",
        check=positive_in(hint="a ratio of energies, such as 10"),
        parse=positive,
        metavar="K",
    )

    def as_dict(self) -> dict:
        return {"limit_factor": self.limit_factor, "pinv_factor": self.pinv_factor, "energy_factor": self.energy_factor}


def self_motion_energy(robot: Robot, result: SimResult) -> tuple[np.ndarray, np.ndarray]:
    r"""(kinetic energy :math:`\tfrac12\dot q^\top H\dot q`, self-motion energy :math:`E_N`) at every sample [J].

    Computed from a finished run with Pinocchio's CRBA and frame Jacobian at
    each recorded state, by :func:`torqueopt.self_motion.self_motion` (the
    figure ``energy-bounded-torque`` bounds; the batched path computes the
    same figures as it goes, ``torqueopt.batch.BatchExtras``).
    """
    model, data = robot.model, robot.model.createData()
    count = len(result.t)
    kinetic, self_energy = np.empty(count), np.empty(count)
    for row in range(count):
        q, v = result.q[row], result.v[row]
        inertia = pin.crba(model, data, q)
        inertia = np.triu(inertia) + np.triu(inertia, 1).T
        jacobian = pin.computeFrameJacobian(model, data, q, robot.frame_id, _LWA)[robot.task_rows]
        null_space_basis = np.linalg.svd(jacobian)[2][robot.m :].T
        part = self_motion(inertia, null_space_basis, v)
        kinetic[row], self_energy[row] = part.kinetic_energy, part.energy
    return kinetic, self_energy


def applied_rows(result: SimResult, *per_sample):
    """``result`` (and the per-sample arrays) without a final sample at t = T, whose torque is never applied."""
    count = len(result.t)
    if count and result.t[-1] > result.duration - 0.5 * result.dt:
        keep = slice(0, count - 1)
        arrays = {
            item.name: getattr(result, item.name)[keep]
            for item in fields(result)
            if item.name not in _PER_JOINT_FIELDS
            and isinstance(getattr(result, item.name), np.ndarray)
            and len(getattr(result, item.name)) == count
        }
        result = replace(result, **arrays)
        per_sample = tuple(values[keep] for values in per_sample)
    return (result, *per_sample)


def _wrapped(angle: np.ndarray) -> np.ndarray:
    return (angle + math.pi) % (2 * math.pi) - math.pi


def run_row(
    result: SimResult,
    kinetic_energy: np.ndarray,
    self_energy: np.ndarray,
    pinv_peak_ratio: float,
    thresholds: Thresholds,
) -> dict:
    """The verdict columns of one run (see the module docstring); energies per sample [J].

    Torque figures (the 2x-limit rule, peak ratio, first violation) read the
    applied torques only: the sample at t = T is the state the run ends in,
    its torque is never held over a step.
    """
    tip_error = float(result.max_tip_error)
    # Every sample counts for the joint limits, the final state too: it is a state the arm reaches.
    position_violation, velocity_violation = result.first_position_violation, result.first_velocity_violation
    result, kinetic_energy, self_energy = applied_rows(result, kinetic_energy, self_energy)
    report = detect_whiplash(result, limit_factor=thresholds.limit_factor)
    # Rows without an applied torque (a singular stop) hold NaN: they count as no demand.
    ratios = np.nan_to_num(result.torque_ratio, nan=-np.inf)
    limited = np.isfinite(result.torque_upper)
    count = len(result.t)
    peak_ratio, peak_joint = math.nan, None
    if count and limited.any() and np.isfinite(ratios[:, limited]).any():
        peak_ratio = float(ratios[:, limited].max())
        peak_joint = str(np.asarray(result.joint_names)[limited][int(np.argmax(ratios[:, limited].max(axis=0)))])
    violation = result.first_limit_violation

    task_energy = np.maximum(kinetic_energy - self_energy, 0.0)
    running_self = np.maximum.accumulate(self_energy) if count else self_energy
    running_task = np.maximum.accumulate(task_energy) if count else task_energy
    with np.errstate(divide="ignore", invalid="ignore"):
        running_ratio = np.where(running_task > 0, running_self / running_task, np.where(running_self > 0, np.inf, 0.0))
    energy_ratio = float(running_ratio[-1]) if count else math.nan
    over_energy = running_ratio > thresholds.energy_factor
    runaway_time = float(result.t[int(np.argmax(over_energy))]) if over_energy.any() else math.nan
    torque_vs_pinv = peak_ratio / pinv_peak_ratio if pinv_peak_ratio > 0 else math.nan
    runaway = bool(over_energy.any() or (math.isfinite(torque_vs_pinv) and torque_vs_pinv > thresholds.pinv_factor))

    verdict = _verdict(result, report, runaway, position_violation, velocity_violation, tip_error)
    whip = (
        _whip(result, report, ratios) if count else dict(zip(_WHIP_COLUMNS, (math.nan, None, math.nan, None, math.nan)))
    )
    return {
        "unstable": bool(report.unstable),
        "verdict": verdict,
        "instability_time": math.nan if report.time is None else float(report.time),
        "peak_torque_ratio": peak_ratio,
        "first_limit_violation": math.nan if violation is None else float(violation),
        "max_tip_error": tip_error,
        "instability_joint": report.joint,
        "peak_torque_joint": peak_joint,
        "first_limit_violation_joint": result.first_limit_violation_joint,
        "first_position_limit_violation": math.nan if position_violation is None else position_violation[0],
        "position_limit_joint": None if position_violation is None else position_violation[1],
        "first_velocity_limit_violation": math.nan if velocity_violation is None else velocity_violation[0],
        "velocity_limit_joint": None if velocity_violation is None else velocity_violation[1],
        "runaway": runaway,
        "runaway_time": runaway_time,
        "torque_vs_pinv": torque_vs_pinv,
        "self_motion_energy_ratio": energy_ratio,
        "peak_self_motion_energy": float(self_energy.max()) if count else math.nan,
        "peak_kinetic_energy": float(kinetic_energy.max()) if count else math.nan,
        **whip,
        # Resolvers under torque bounds give up task acceleration instead of exceeding a limit.
        "max_task_error": float(np.nanmax(result.task_error)) if count else 0.0,
        "infeasible_steps": int(np.count_nonzero(result.infeasible)),
        "completed": bool(result.completed),
        "stop_reason": result.stop_reason,
        "simulated_time": float(result.t[-1]) if count else 0.0,
        "steps": count,
    }


def _verdict(result: SimResult, report, runaway: bool, position_violation, velocity_violation, tip_error) -> str:
    """The verdict of a run (the module docstring), from its 2x-limit report and runaway flag."""
    if report.unstable:
        from_the_start = report.time is not None and report.time <= result.t[0]
        return "whiplash" if runaway and not from_the_start else "too demanding"
    if position_violation is not None or velocity_violation is not None:
        return "joint limits"
    # The task Jacobian's singularity, or an algorithmic one (the extended Jacobian's), even at t = 0.
    if result.stop_reason is not None and "Jacobian is singular" in result.stop_reason:
        return "singular"
    if tip_error > DEFAULT_PATH_TOLERANCE or math.isnan(tip_error):
        return "lost path"
    return "stable" if result.completed else "stopped early"


_WHIP_COLUMNS = ("whip_time", "aligned_joint", "aligned_angle", "whip_speed_joint", "whip_speed")


def _whip(result: SimResult, report, ratios: np.ndarray) -> dict:
    """Where the whip happened: at the instability, else at the peak demand (a run with samples)."""
    whip_row = int(np.argmax(result.t >= report.time)) if report.unstable else int(np.argmax(ratios.max(axis=1)))
    angles = _wrapped(result.joint_angles[whip_row])
    candidates = np.arange(1, result.n) if result.n > 1 else np.arange(result.n)
    aligned = int(candidates[np.argmin(np.abs(angles[candidates]))])
    speeds = np.abs(result.v[whip_row])
    fastest = int(np.argmax(speeds))
    values = (
        float(result.t[whip_row]),
        result.joint_names[aligned],
        float(angles[aligned]),
        result.joint_names[fastest],
    )
    return dict(zip(_WHIP_COLUMNS, (*values, float(speeds[fastest]))))

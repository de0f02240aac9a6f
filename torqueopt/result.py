"""The result of a simulation and its summary figures.

:class:`SimResult` holds a run's arrays and computes its peaks, ratios and
first violations; its files (CSV with a JSON sidecar, or ``.npz``) are
written and read by :mod:`torqueopt.result_files` (:meth:`SimResult.to_csv`,
:func:`load_result`).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .result_files import csv_columns, json_number, read_result, write_result
from .units import joint_unit

__all__ = ["SimResult", "load_result"]


@dataclass
class SimResult:
    """A simulated run, one row per step start.

    Attributes:
        t: times [s], shape (N,).
        q: configuration vectors, (N, nq).
        joint_angles: one coordinate per joint [rad or m], (N, n).
        v: joint velocities [rad/s], (N, n).
        acceleration: joint accelerations the resolver commanded [rad/s²], (N, n).
        tau: joint torques held over each step [N·m], (N, n). The last row
            of a completed run (t = duration) holds NaN: it is the final
            state, from which no torque is applied. Peaks, ratios and
            violations count only the torques the rows hold.
        x: task coordinates of the tip [m, rad], (N, m).
        x_ref: reference task coordinates [m, rad], (N, m).
        jacobian_inverse_condition: σ_min/σ_max of the task Jacobian, the reciprocal of its
            condition number, in (0, 1], (N,); 0 near a singularity.
        torque_upper: torque limits τ⁺ [N·m] (+inf: unbounded).
        torque_lower: torque limits τ⁻ [N·m] (−inf: unbounded).
        duration: the requested simulated time [s].
        stop_reason: why the run ended early, None when it completed.
        stop_time: when it ended early [s], None when it completed.
        trajectory: what the tip followed, as :meth:`Trajectory.describe`
            gives it (kind, parameters, start, duration); None when unknown
            (a result built by hand).
        task_error: per row, the task acceleration the resolver gave up,
            ‖J q̈ + J̇q̇ − ẍ‖ [m/s², rad/s²], (N,); zeros when not given.
        infeasible: per row, True where no admissible torque realised the task, (N,).
        limiting: the infeasible rows' bounds, ``{row: text}``: which bounds (torque, joint
            position, velocity, acceleration; which joint, which side) each answer lay on,
            as the bounded resolvers report them (None when no row has any; not kept in files).
        resolver_options: the resolver's option values, JSON-ready (None when unknown).
        dexterity: per-row dexterity measures keyed by name (each (N,)), as
            :func:`torqueopt.dexterity_along` gives them; None
            unless asked for (``simulate(..., dexterity=True)``).
        joint_limits: the URDF's joint position and velocity limits, as
            ``joint_limits_record`` keeps them (``position_lower``,
            ``position_upper``, ``velocity``: one value per joint, None where
            unbounded); None when unknown. :attr:`first_position_violation` and
            :attr:`first_velocity_violation` say when a run first left them.
        plant: what the torque acted on, as the plant's ``record()`` gives it
            (:mod:`torqueopt.plants`): ``{"name": "pinocchio", ...}`` or the
            MuJoCo model, its options, notes and joint-limit events; None in
            files written before it was recorded.
        stability_margin: per row, the growth rate of the linearised closed-loop
            self-motion [1/s] (:func:`torqueopt.stability_margin`; NaN where no torque
            was applied), (N,); None unless asked for (``simulate(..., margin=True)``).
        joint_kinds: per joint, 'revolute', 'continuous' or 'prismatic', which sets its units (rad, rad/s, N·m or
            m, m/s, N: :mod:`torqueopt.units`); None in files written before it was recorded (read as revolute).
        gravity: the gravity vector of the run's model in world axes [m/s²]; None in files
            written before it was recorded.
        payload: the load the task frame carried, as :meth:`torqueopt.Payload.record` gives it
            (``mass`` [kg], ``position`` in the task frame [m], ``inertia`` [kg·m²]); None without one.
        robot_source: what rebuilds the robot for playback, as :func:`torqueopt.run_robot.robot_record`
            gives it: the URDF's absolute path and SHA-256, the locked joints and the configuration
            they are held at; None for a robot built without a URDF and in files written before it
            was recorded.
        joint_dynamics: the URDF's joint damping and friction and whether the run
            modelled them, as ``joint_dynamics_record`` keeps them (``setting``,
            ``modelled``, ``damping`` [N·m·s/rad], ``friction`` [N·m],
            ``friction_velocity_scale`` [rad/s] per joint); None when the URDF has neither.
            :attr:`damping_torque` and :attr:`friction_torque` are their shares
            of each row's torque.
        settings: the settings of the command that made the run, by name, as its settings dataclass records
            them (``torqueopt run``'s ``RunSettings``); None for a run made through the
            API (and not written to its files then).
    """

    robot: str
    frame: str
    task: str
    resolver: str
    joint_names: list[str]
    dt: float
    t: np.ndarray
    q: np.ndarray
    joint_angles: np.ndarray
    v: np.ndarray
    acceleration: np.ndarray
    tau: np.ndarray
    x: np.ndarray
    x_ref: np.ndarray
    jacobian_inverse_condition: np.ndarray
    torque_upper: np.ndarray
    torque_lower: np.ndarray
    duration: float
    stop_reason: str | None = None
    stop_time: float | None = None
    trajectory: dict | None = None
    task_error: np.ndarray | None = None
    infeasible: np.ndarray | None = None
    resolver_options: dict | None = None
    dexterity: dict[str, np.ndarray] | None = None
    joint_limits: dict | None = None
    limiting: dict[int, str] | None = None
    plant: dict | None = None
    stability_margin: np.ndarray | None = None
    joint_kinds: list[str] | None = None
    gravity: list[float] | None = None
    payload: dict | None = None
    robot_source: dict | None = None
    joint_dynamics: dict | None = None
    settings: dict | None = None

    def __post_init__(self):
        # A result built by hand without them realised its task at every row.
        rows = len(self.t)
        self.task_error = np.zeros(rows) if self.task_error is None else np.asarray(self.task_error, dtype=float)
        self.infeasible = (
            np.zeros(rows, dtype=bool) if self.infeasible is None else np.asarray(self.infeasible, dtype=bool)
        )

    def joint_unit(self, joint: int, quantity: str) -> str:
        """The unit of ``quantity`` (``position``, ``velocity``, ``acceleration``, ``torque``) for joint ``joint``."""
        return joint_unit(self.joint_kinds[joint] if self.joint_kinds else None, quantity)

    # -- joint position and velocity limits --------------------------------------
    def _joint_limit(self, key: str, fill: float) -> np.ndarray:
        values = (self.joint_limits or {}).get(key)
        if values is None:
            return np.full(self.n, fill)
        return np.array([fill if value is None else value for value in values], dtype=float)

    @property
    def position_lower(self) -> np.ndarray:
        """Per joint, the URDF's lower position limit [rad or m]; -inf where there is none."""
        return self._joint_limit("position_lower", -np.inf)

    @property
    def position_upper(self) -> np.ndarray:
        """Per joint, the URDF's upper position limit [rad or m]; inf where there is none."""
        return self._joint_limit("position_upper", np.inf)

    @property
    def velocity_limit(self) -> np.ndarray:
        """Per joint, the URDF's velocity limit [rad/s or m/s]; inf where there is none."""
        return self._joint_limit("velocity", np.inf)

    def _first_outside(self, values: np.ndarray, lower: np.ndarray, upper: np.ndarray):
        """(time, joint, value, the limit it crossed) of the first row where a value leaves [lower, upper], or None."""
        if not len(self.t):
            return None
        # A relative 1e-9 of slack: a joint that starts exactly at its limit has not left it.
        slack = 1e-9 * np.maximum(1.0, np.abs(np.where(np.isfinite(upper), upper, 0.0)))
        outside = (values < lower - slack) | (values > upper + slack)
        rows = outside.any(axis=1)
        if not rows.any():
            return None
        row = int(np.argmax(rows))
        joint = int(np.argmax(outside[row]))
        value = float(values[row, joint])
        limit = float(lower[joint] if value < lower[joint] else upper[joint])
        return float(self.t[row]), self.joint_names[joint], value, limit

    @property
    def first_position_violation(self):
        """(time [s], joint, angle, limit) when a joint first leaves its URDF position limits, or None."""
        return self._first_outside(self.joint_angles, self.position_lower, self.position_upper)

    @property
    def first_velocity_violation(self):
        """(time [s], joint, velocity, ±limit) when a joint first exceeds its URDF velocity limit, or None."""
        return self._first_outside(self.v, -self.velocity_limit, self.velocity_limit)

    # -- joint damping and friction ----------------------------------------------
    @property
    def models_joint_dynamics(self) -> bool:
        """True when the run's torques include the URDF's joint damping or friction (``--joint-dynamics urdf``)."""
        return bool(self.joint_dynamics and self.joint_dynamics["modelled"])

    def _joint_dynamics_share(self, torque: np.ndarray) -> np.ndarray:
        # Rows without an applied torque (the final state) hold NaN, as tau does.
        return np.where(np.isnan(self.tau), np.nan, torque)

    @property
    def damping_torque(self) -> np.ndarray | None:
        r"""Per row and joint, the damping torque :math:`D\dot q` the run's torque includes [N·m], (N, n); None when
        the run did not model joint dynamics."""
        if not self.models_joint_dynamics:
            return None
        return self._joint_dynamics_share(np.asarray(self.joint_dynamics["damping"], float) * self.v)

    @property
    def friction_torque(self) -> np.ndarray | None:
        r"""Per row and joint, the friction torque :math:`F\tanh(\dot q/v_s)` the run's torque includes [N·m],
        (N, n); None when the run did not model joint dynamics."""
        if not self.models_joint_dynamics:
            return None
        record = self.joint_dynamics
        scale = np.asarray(record["friction_velocity_scale"], float)
        return self._joint_dynamics_share(np.asarray(record["friction"], float) * np.tanh(self.v / scale))

    # -- summary ---------------------------------------------------------------
    @property
    def completed(self) -> bool:
        """True when the run reached its duration."""
        return self.stop_reason is None

    @property
    def n(self) -> int:
        return self.tau.shape[1]

    @property
    def m(self) -> int:
        return self.x.shape[1]

    @property
    def peak_torque(self) -> np.ndarray:
        """Per joint, the largest ``|τ|`` over the run [N·m]."""
        return _column_peak(np.abs(self.tau), self.n)

    @property
    def torque_ratio(self) -> np.ndarray:
        """``|τ|`` / limit per row and joint, (N, n); 0 for unbounded joints."""
        upper = np.where(np.isfinite(self.torque_upper), self.torque_upper, np.inf)
        lower = np.where(np.isfinite(self.torque_lower), self.torque_lower, -np.inf)
        return np.where(self.tau >= 0, self.tau / upper, self.tau / lower)

    @property
    def peak_torque_ratio(self) -> np.ndarray:
        """Per joint, the largest ``|τ|``/limit over the run (above 1: the limit was exceeded)."""
        return _column_peak(self.torque_ratio, self.n)

    @property
    def first_limit_violation(self) -> float | None:
        """First time any torque exceeds its limit [s], or None."""
        index = self._first_violation_index()
        return None if index is None else float(self.t[index])

    @property
    def first_limit_violation_joint(self) -> str | None:
        """Name of the joint that first exceeds its limit, or None."""
        index = self._first_violation_index()
        if index is None:
            return None
        return self.joint_names[int(np.argmax(self.torque_ratio[index]))]

    def _first_violation_index(self) -> int | None:
        over = (self.torque_ratio > 1.0).any(axis=1)
        return int(np.argmax(over)) if over.any() else None

    @property
    def tip_error(self) -> np.ndarray:
        """Distance between tip and reference position per row [m]."""
        linear = min(self.m, 3)
        return np.linalg.norm(self.x[:, :linear] - self.x_ref[:, :linear], axis=1)

    @property
    def max_tip_error(self) -> float:
        """Largest tip position error over the run [m]."""
        return float(self.tip_error.max()) if len(self.t) else 0.0

    @property
    def max_orientation_error(self) -> float | None:
        r"""Largest orientation error for the ``pose`` task [rad], else None: the angle between the frame's
        rotation and the reference's, :math:`|\log(\exp(x_{ref}) \exp(x)^\top)|` from their rotation vectors
        about the start rotation, which is :math:`|x - x_{ref}|` where the reference holds the start (x_ref = 0)."""
        if self.m != 6 or not len(self.t):
            return None
        error = np.linalg.norm(self.x[:, 3:] - self.x_ref[:, 3:], axis=1)
        turning = np.flatnonzero(self.x_ref[:, 3:].any(axis=1))
        if turning.size:
            import pinocchio as pin

            error[turning] = [
                np.linalg.norm(pin.log3(pin.exp3(self.x_ref[row, 3:]).dot(pin.exp3(self.x[row, 3:]).T)))
                for row in turning
            ]
        return float(error.max())

    @property
    def max_task_error(self) -> float:
        """Largest task-acceleration shortfall over the run [m/s², rad/s²]; 0 when every step realised its task."""
        return float(self.task_error.max()) if len(self.task_error) else 0.0

    @property
    def infeasible_steps(self) -> int:
        """How many steps found no admissible torque that realises the task."""
        return int(np.count_nonzero(self.infeasible))

    @property
    def first_infeasible_step(self) -> tuple[float, str] | None:
        """(time [s], the bounds its answer lay on) of the first infeasible step, or None when there is none."""
        if not self.infeasible.any():
            return None
        row = int(np.argmax(self.infeasible))
        return float(self.t[row]), (self.limiting or {}).get(row, "")

    def summary(self) -> dict:
        """The run's figures as plain JSON-ready values."""
        return {
            "robot": self.robot,
            "frame": self.frame,
            "task": self.task,
            "resolver": self.resolver,
            "duration": self.duration,
            "simulated_time": float(self.t[-1]) if len(self.t) else 0.0,
            "completed": self.completed,
            "stop_reason": self.stop_reason,
            "stop_time": self.stop_time,
            "joint_names": list(self.joint_names),
            "joint_kinds": self.joint_kinds,
            "peak_torque": self.peak_torque.tolist(),
            "torque_limit": [json_number(x) for x in self.torque_upper],
            "peak_torque_ratio": self.peak_torque_ratio.tolist(),
            "first_limit_violation": self.first_limit_violation,
            "first_limit_violation_joint": self.first_limit_violation_joint,
            "max_tip_error": self.max_tip_error,
            "max_orientation_error": self.max_orientation_error,
            "max_task_error": self.max_task_error,
            "infeasible_steps": self.infeasible_steps,
            "first_infeasible_step": (
                None if self.first_infeasible_step is None else dict(zip(("t", "limiting"), self.first_infeasible_step))
            ),
            "resolver_options": self.resolver_options,
            "first_position_violation": _violation_json(self.first_position_violation),
            "first_velocity_violation": _violation_json(self.first_velocity_violation),
            "plant": self.plant,
        } | ({} if self.joint_dynamics is None else {"joint_dynamics": self._joint_dynamics_summary()})

    def _joint_dynamics_summary(self) -> dict:
        """The record, with the peak damping and friction torques per joint when the run modelled them."""
        summary = dict(self.joint_dynamics)
        if self.models_joint_dynamics:
            summary["peak_damping_torque"] = _column_peak(np.abs(self.damping_torque), self.n).tolist()
            summary["peak_friction_torque"] = _column_peak(np.abs(self.friction_torque), self.n).tolist()
        return summary

    # -- files -----------------------------------------------------------------
    def csv_columns(self) -> list[str]:
        """Column names: t, q1..qn, v1..vn, tau1..taun, x1..xm, xref1..xrefm, task_error, infeasible
        (then damping1..dampingn, friction1..frictionn when the run modelled joint dynamics)."""
        return csv_columns(self.n, self.m, self.models_joint_dynamics)

    def to_csv(self, path: str | os.PathLike) -> Path:
        """Write the run to ``path``: CSV with its ``<path>.json`` sidecar, or NumPy ``.npz`` when the path ends so
        (the formats: docs/files.md); the files land together or not at all."""
        return write_result(self, path)

    def __repr__(self) -> str:
        status = "completed" if self.completed else f"stopped: {self.stop_reason}"
        return f"SimResult({self.robot}, {self.resolver}, {len(self.t)} rows, {status})"


def _column_peak(values: np.ndarray, n: int) -> np.ndarray:
    """Per column, the largest value that is not NaN (0 for a column with none); inf counts."""
    if not len(values):
        return np.zeros(n)
    return np.where(np.isnan(values), -np.inf, values).max(axis=0).clip(min=0.0)


def _violation_json(violation) -> dict | None:
    if violation is None:
        return None
    time, joint, value, limit = violation
    return {"time": time, "joint": joint, "value": value, "limit": limit}


def joint_dynamics_record(robot) -> dict | None:
    """The URDF's joint damping and friction and whether ``robot`` models them, JSON-ready; None when it has neither."""
    if not robot.urdf_has_joint_dynamics:
        return None
    return {
        "setting": robot.joint_dynamics,
        "modelled": robot.models_joint_dynamics,
        "damping": robot.urdf_joint_damping.tolist(),
        "friction": robot.urdf_joint_friction.tolist(),
        "friction_velocity_scale": robot.friction_velocity_scale.tolist(),
    }


def joint_limits_record(lower, upper, velocity) -> dict:
    """Joint limits as a :class:`SimResult` records them: JSON-ready lists, None where unbounded."""
    return {
        "position_lower": [json_number(x) for x in lower],
        "position_upper": [json_number(x) for x in upper],
        "velocity": [json_number(x) for x in velocity],
    }


def load_result(path: str | os.PathLike, robot=None) -> SimResult:
    """Read a run written by :meth:`SimResult.to_csv` (CSV with its JSON sidecar, or .npz).

    A CSV holds one angle per joint, not configuration vectors: with ``robot``
    given, ``q`` is rebuilt from them (needed for continuous joints, whose
    configuration is (cos, sin)); without it ``q`` holds the angles. A CSV
    has no joint accelerations or Jacobian condition: those arrays are NaN.

    Raises:
        InvalidInput: the file is missing or is not a run file.
    """
    return read_result(path, SimResult, robot)

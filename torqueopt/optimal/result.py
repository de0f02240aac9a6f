"""The result of a whole-movement torque optimisation (:func:`torqueopt.optimize`), on the simulation grid."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..result import SimResult
from ..result_files import json_number

__all__ = ["OptimalResult"]


@dataclass
class OptimalResult:
    """A whole-movement torque optimisation, on the simulation grid t_0 = 0, dt, ..., T.

    Attributes:
        t: times [s], (M+1,). q: configurations, (M+1, nq). joint_angles: (M+1, n) [rad].
        v: joint velocities [rad/s]. acceleration: planned joint accelerations [rad/s²].
        tau: torque held over each step [N·m], (M+1, n); the last row (t = T)
            is NaN, as in a SimResult: no torque is applied after the movement.
        x: the planned tip (task coordinates) [m]. x_ref: the reference [m].
        replay_x: the tip of the open-loop replay [m] (NaN after a non-finite state).
        cost: the sum over applied torques of dt·‖S(τ_j − τ_mid)‖² on this grid
            ([N²·m²·s] for S = I). grid_cost: the same on the transcription grid (the NLP's objective).
        status: one of ``converged``, ``acceptable``, ``iteration limit``,
            ``time limit``, ``infeasible``, ``failed``. solver_message: IPOPT's return status.
        replay_tip_error: largest tip deviation of the replay from the reference [m].
        plan_tip_error: largest tip deviation of the planned motion between nodes [m].
        constraint_violation: largest violation of the NLP's constraints at the returned point.
        warm_start: the resolver whose run started the solve; warm_start_cost: its cost on this grid.
    """

    robot: str
    frame: str
    task: str
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
    replay_x: np.ndarray
    torque_upper: np.ndarray
    torque_lower: np.ndarray
    duration: float
    cost: float
    grid_cost: float
    weight: str
    status: str
    solver_message: str
    iterations: int
    solve_seconds: float
    replay_tip_error: float
    plan_tip_error: float
    constraint_violation: float
    grid_step: float
    grid_intervals: int
    end: str
    torque_bounds: bool
    joint_limits: bool
    trajectory: dict
    hessian: str
    warm_start: str
    warm_start_cost: float
    #: ``direct`` or ``shooting`` (``torqueopt.optimal.TRANSCRIPTIONS``).
    transcription: str = "direct"
    #: Every start the ``shooting`` transcription solved from: warm_start, status, solver_message,
    #: iterations, grid_cost, constraint_violation, seconds (empty for ``direct``).
    starts: list = field(default_factory=list)
    #: ``shooting`` only, when no start ended within the limits: the phase-1 problem's answer
    #: (``torqueopt.optimal.shooting.Feasibility.record``: excess, status, binding limits, evidence); else empty.
    feasibility: dict = field(default_factory=dict)
    #: The solver's multipliers and the transcription, for checks (not written to files).
    solution: dict = field(default_factory=dict, repr=False)
    #: Per joint, 'revolute', 'continuous' or 'prismatic' (as ``SimResult.joint_kinds``).
    joint_kinds: list | None = None
    #: What rebuilds the robot for playback (:func:`torqueopt.run_robot.robot_record`).
    robot_source: dict | None = field(default=None, repr=False)

    @property
    def optimal(self) -> bool:
        """True only when IPOPT converged to its tolerance."""
        return self.status == "converged"

    @property
    def peak_torque(self) -> np.ndarray:
        """Per joint, the largest applied ``|τ|`` [N·m]."""
        return np.abs(self.tau[:-1]).max(axis=0)

    @property
    def peak_torque_ratio(self) -> np.ndarray:
        """Per joint, the largest applied ``|τ|`` / limit (0 where unbounded)."""
        upper = np.where(np.isfinite(self.torque_upper), self.torque_upper, np.inf)
        lower = np.where(np.isfinite(self.torque_lower), self.torque_lower, -np.inf)
        applied = self.tau[:-1]
        return np.where(applied >= 0, applied / upper, applied / lower).max(axis=0)

    def as_sim_result(self) -> SimResult:
        """The planned motion and its torques as a :class:`SimResult` (resolver ``optimal``), for plots and files."""
        return SimResult(
            robot=self.robot,
            frame=self.frame,
            task=self.task,
            resolver="optimal",
            joint_names=list(self.joint_names),
            joint_kinds=self.joint_kinds,
            robot_source=self.robot_source,
            dt=self.dt,
            t=self.t,
            q=self.q,
            joint_angles=self.joint_angles,
            v=self.v,
            acceleration=self.acceleration,
            tau=self.tau,
            x=self.x,
            x_ref=self.x_ref,
            jacobian_inverse_condition=np.full(len(self.t), np.nan),
            torque_upper=self.torque_upper,
            torque_lower=self.torque_lower,
            duration=self.duration,
            trajectory=self.trajectory,
        )

    def summary(self) -> dict:
        """The optimisation's figures as plain JSON-ready values."""
        return {
            "robot": self.robot,
            "frame": self.frame,
            "task": self.task,
            "duration": self.duration,
            "status": self.status,
            "optimal": self.optimal,
            "solver_message": self.solver_message,
            "iterations": self.iterations,
            "solve_seconds": self.solve_seconds,
            "cost": self.cost,
            "cost_unit": "N^2 m^2 s" if self.weight == "identity" else "weighted",
            "grid_cost": self.grid_cost,
            "weight": self.weight,
            "end": self.end,
            "torque_bounds": self.torque_bounds,
            "joint_limits": self.joint_limits,
            "trajectory": self.trajectory,
            "hessian": self.hessian,
            "grid_step": self.grid_step,
            "grid_intervals": self.grid_intervals,
            "dt": self.dt,
            "joint_names": list(self.joint_names),
            "peak_torque": self.peak_torque.tolist(),
            "torque_limit": [json_number(x) for x in self.torque_upper],
            "peak_torque_ratio": self.peak_torque_ratio.tolist(),
            "replay_tip_error": self.replay_tip_error,
            "plan_tip_error": self.plan_tip_error,
            "constraint_violation": self.constraint_violation,
            "warm_start": self.warm_start,
            "warm_start_cost": self.warm_start_cost,
            "transcription": self.transcription,
            "starts": [dict(record) for record in self.starts],
            "feasibility": dict(self.feasibility),
        }

    def to_csv(self, path):
        """Write the planned run like ``torqueopt run --out`` (CSV + sidecar, or .npz), plus ``<path>.optimal.json``.

        The run file is readable by :func:`torqueopt.load_result` and
        ``torqueopt plot``/``play``; the ``.optimal.json`` file holds
        :meth:`summary`. The files land together or not at all, the sidecars
        beside the file the data went to (see :meth:`files`).
        """
        import json

        from ..io import atomic_write, sidecar_path, written_together

        text = json.dumps(self.summary(), indent=2).encode()
        with written_together():
            path = self.as_sim_result().to_csv(path)
            atomic_write(sidecar_path(path, ".optimal.json"), lambda handle: handle.write(text))
        return path

    @staticmethod
    def files(path) -> list:
        """The files :meth:`to_csv` writes for ``path``: the run's (:func:`~torqueopt.result_files.run_files`) and ``.optimal.json``."""
        from ..io import sidecar_path
        from ..result_files import run_files

        return [*run_files(path), sidecar_path(path, ".optimal.json")]

    def __repr__(self) -> str:
        return (
            f"OptimalResult({self.robot}, {self.status}, cost={self.cost:.6g}, "
            f"replay_tip_error={self.replay_tip_error:.3g} m, {len(self.t)} rows)"
        )

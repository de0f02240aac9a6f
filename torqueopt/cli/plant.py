"""``--plant``, ``--mjcf`` and ``--plant-option``: what the resolver's torque acts on (:mod:`torqueopt.plants`)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..errors import InvalidInput
from ..plants import Plant, make_plant, plant_names, plant_option_texts
from ..plants.mujoco import OPTIONS as MUJOCO_OPTIONS
from ..result import SimResult
from ..settings import Settings, setting

__all__ = ["RunPlantSettings", "plant_summary"]

#: The plant options ``--plant-option`` takes, with the defaults ``--help`` states: the MuJoCo plant's.
PLANT_OPTIONS = MUJOCO_OPTIONS


def _plant_option_values(texts, name) -> dict[str, str]:
    options = plant_option_texts(texts)
    unknown = [key for key in options if key not in PLANT_OPTIONS]
    if unknown:
        raise InvalidInput(f"unknown --plant-option '{unknown[0]}'; the options are {', '.join(PLANT_OPTIONS)}")
    return options


@dataclass(frozen=True)
class RunPlantSettings(Settings):
    """``--plant``, ``--mjcf`` and ``--plant-option``: the plant of one run (:meth:`plant`)."""

    TITLE = "plant (what the torque acts on)"

    plant: str | None = setting(
        None,
        "pinocchio: the robot's own model, RK4 with the torque held (the paper's); mujoco: a MuJoCo model of "
        "the arm (its URDF compiled by MuJoCo, or --mjcf) advanced by MuJoCo, the torque computed from its state "
        "(needs pip install 'torqueopt[mujoco]'); default pinocchio, mujoco with --mjcf",
        choices=tuple(plant_names()),
    )
    mjcf: str | None = setting(
        None,
        "a MuJoCo MJCF model as the plant (implies --plant mujoco), its joint names matching the URDF's; "
        "the controller still uses the URDF",
        metavar="FILE",
    )
    plant_options: dict[str, str] = setting(
        (),
        lambda: (
            "a MuJoCo plant option, repeatable or comma-separated: "
            + "; ".join(f"{key}= {text} (default {default})" for key, (default, text) in PLANT_OPTIONS.items())
        ),
        check=lambda value, name: dict(value),
        flag="--plant-option",
        repeat=True,
        metavar="KEY=VALUE",
        parse=_plant_option_values,
    )

    def build(self, robot) -> Plant:
        """The plant these settings name, built (and checked) before any run."""
        options = dict(self.plant_options)
        name = self.plant or ("mujoco" if self.mjcf else "pinocchio")
        if name != "mujoco" and (self.mjcf or options):
            given = "--mjcf" if self.mjcf else "--plant-option"
            raise InvalidInput(f"{given} applies to --plant mujoco, not --plant {name}")
        if self.mjcf:
            options["mjcf"] = self.mjcf
        return make_plant(robot, name, options)


def plant_summary(result: SimResult) -> list[str]:
    """The summary's lines on a MuJoCo plant: its model and options, its notes, the joint-limit forces that acted."""
    record = result.plant or {}
    if record.get("name") != "mujoco":
        return []
    substeps = record.get("substeps") or 1
    lines = [
        f"plant: MuJoCo {record['mujoco_version']} on {record['model'].upper()} {Path(record['model_file']).name}, "
        f"{record['integrator']} at "
        f"{record['timestep'] * 1e3:g} ms ({substeps} step{'s' if substeps != 1 else ''} per control step), "
        f"contacts {record['contacts']}, joint limits {record['joint_limits']}, damping {record['damping']}"
    ]
    perturbation = record.get("perturbation")
    if perturbation:
        lines.append(
            f"plant perturbed: {len(perturbation['links'])} link masses and inertias scaled by factors from "
            f"U({1 - perturbation['fraction']:g}, {1 + perturbation['fraction']:g}), seed {perturbation['seed']}"
        )
    lines += [f"plant note: {note}" for note in record.get("notes", [])]
    if record.get("joint_limits") == "on":
        events = record.get("limit_events") or []
        if not events:
            lines.append("joint-limit force: none acted (no joint reached its limit in MuJoCo)")
        for event in events:
            joint = list(result.joint_names).index(event["joint"]) if event["joint"] in result.joint_names else None
            unit = result.joint_unit(joint, "torque") if joint is not None else "N·m"
            lines.append(
                f"joint-limit force: MuJoCo's limit stopped joint {event['joint']} from t = {event['first_time']:.3f} s "
                f"(peak {event['peak_force']:.4g} {unit}, {event['steps']} MuJoCo steps)"
            )
    return lines

"""The run files: a :class:`~torqueopt.result.SimResult` written to and read from disk (the formats: docs/files.md).

A CSV (one row per step, its columns read by name) with a ``<path>.json`` sidecar for what the columns cannot
hold, or a NumPy ``.npz`` with every array and the same metadata; written through
:func:`torqueopt.io.atomic_write` inside :func:`torqueopt.io.written_together`, so a run's files land together.
"""

from __future__ import annotations

import json
import os
import warnings
import zipfile
from dataclasses import fields
from pathlib import Path

import numpy as np

from .errors import InvalidInput
from .io import atomic_write, sidecar_path, written_together

__all__ = ["csv_columns", "read_result", "run_files", "write_result"]

#: The per-step columns after xref, in this order.
_STEP_COLUMNS = ("task_error", "infeasible")
#: The stability margin's column (CSV) and array (.npz) [1/s], when the run recorded it.
_MARGIN = "stability_margin"
#: Prefix of the dexterity arrays in a ``.npz`` run file.
_DEXTERITY_KEY = "dexterity_"
_ARRAY_FIELDS = (
    "t", "q", "joint_angles", "v", "acceleration", "tau", "x", "x_ref",
    "jacobian_inverse_condition", "torque_upper", "torque_lower", "task_error", "infeasible",
)  # fmt: skip


def _column_groups(n: int, m: int) -> dict[str, list[str]]:
    """The run CSV's required columns by group: ``t``, ``q1..qn``, ``v1..vn``, ``tau1..taun``, ``x1..xm``,
    ``xref1..xrefm``, ``task_error``, ``infeasible``."""
    indexed = {"q": n, "v": n, "tau": n, "x": m, "xref": m}
    groups = {"t": ["t"], **{name: [f"{name}{i}" for i in range(1, size + 1)] for name, size in indexed.items()}}
    return {**groups, **{name: [name] for name in _STEP_COLUMNS}}


def csv_columns(n: int, m: int, joint_dynamics: bool = False) -> list[str]:
    """The CSV columns of a run of n joints and m task coordinates, before any dexterity measure: those of
    :func:`_column_groups`, then with ``joint_dynamics`` ``damping1..dampingn, friction1..frictionn``."""
    columns = [name for names in _column_groups(n, m).values() for name in names]
    return columns + (_joint_dynamics_columns(n) if joint_dynamics else [])


def _joint_dynamics_columns(n: int) -> list[str]:
    """The damping and friction torque columns of a run that modelled them (derived from v: read, not kept)."""
    return [f"damping{i}" for i in range(1, n + 1)] + [f"friction{i}" for i in range(1, n + 1)]


def run_files(path: str | os.PathLike) -> list[Path]:
    """The files :func:`write_result` writes for ``path``: the ``.npz``, or the CSV and its JSON sidecar."""
    path = Path(path)
    return [path] if path.suffix.lower() == ".npz" else [path, sidecar_path(path)]


def write_result(result, path: str | os.PathLike) -> Path:
    """Write ``result`` to ``path``; :meth:`torqueopt.SimResult.to_csv` documents the formats."""
    with written_together():
        return _write_result(result, Path(path))


def _write_result(result, path: Path) -> Path:
    if path.suffix.lower() == ".npz":
        arrays = {name: getattr(result, name) for name in _ARRAY_FIELDS}
        arrays.update({_DEXTERITY_KEY + name: values for name, values in (result.dexterity or {}).items()})
        if result.stability_margin is not None:
            arrays[_MARGIN] = result.stability_margin
        atomic_write(path, lambda handle: np.savez_compressed(handle, metadata=json.dumps(_metadata(result)), **arrays))
        return path
    dexterity = dict(result.dexterity or {})
    if result.stability_margin is not None:
        dexterity[_MARGIN] = result.stability_margin  # one more per-row column, after the dexterity measures
    table = np.column_stack(
        [
            result.t,
            result.joint_angles,
            result.v,
            result.tau,
            result.x,
            result.x_ref,
            result.task_error,
            result.infeasible,
            *((result.damping_torque, result.friction_torque) if result.models_joint_dynamics else ()),
            *dexterity.values(),
        ]
    )
    header = ",".join([*result.csv_columns(), *dexterity])
    atomic_write(path, lambda handle: np.savetxt(handle, table, delimiter=",", header=header, comments="", fmt="%.10g"))
    sidecar = _metadata(result)
    sidecar["torque_upper"] = [json_number(x) for x in result.torque_upper]
    sidecar["torque_lower"] = [json_number(x) for x in result.torque_lower]
    metadata = json.dumps(sidecar, indent=2).encode()
    atomic_write(sidecar_path(path), lambda handle: handle.write(metadata))
    return path


def _metadata(result) -> dict:
    metadata = {
        f.name: getattr(result, f.name) for f in fields(result) if f.name not in (*_ARRAY_FIELDS, "dexterity", _MARGIN)
    }
    if metadata["settings"] is None:  # a run of the API: its files stay as they were before settings were recorded
        del metadata["settings"]
    return metadata


def read_result(path: str | os.PathLike, result_type, robot=None):
    """:func:`torqueopt.load_result` as a ``result_type`` (:class:`~torqueopt.result.SimResult`, which it passes:
    this module writes and reads its fields, and needs no import of it)."""
    path = Path(path)
    if not path.is_file():
        raise InvalidInput(f"run file '{path}' does not exist")
    try:
        if path.suffix.lower() == ".npz":
            return _load_npz(path, result_type)
        return _load_csv(path, result_type, robot)
    except InvalidInput:
        raise
    except (OSError, ValueError, KeyError, TypeError, IndexError, AttributeError, zipfile.BadZipFile) as error:
        detail = " ".join(str(error).split()) or type(error).__name__
        if isinstance(error, KeyError):
            detail = f"missing field {detail}"
        raise InvalidInput(f"run file '{path}' is malformed ({detail}); write runs with torqueopt run --out") from None


def _load_npz(path: Path, result_type):
    with np.load(path, allow_pickle=False) as archive:
        metadata = json.loads(str(archive["metadata"]))
        arrays = {name: archive[name] for name in _ARRAY_FIELDS}
        dexterity = {
            key[len(_DEXTERITY_KEY) :]: archive[key] for key in archive.files if key.startswith(_DEXTERITY_KEY)
        }
        margin = archive[_MARGIN] if _MARGIN in archive.files else None
    return result_type(**metadata, **arrays, dexterity=dexterity or None, stability_margin=margin)


def _load_csv(path: Path, result_type, robot):
    sidecar = sidecar_path(path)
    if not sidecar.is_file() and Path(f"{path}.json").is_file():
        sidecar = Path(f"{path}.json")  # where earlier versions wrote it, beside the link
    if not sidecar.is_file():
        raise InvalidInput(f"run file '{path}' has no sidecar '{sidecar}'; write runs with torqueopt run --out")
    metadata = json.loads(sidecar.read_text())
    with open(path) as handle:
        header = [name.strip() for name in handle.readline().strip().split(",")]
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="loadtxt: input contained no data")  # a run of no rows: said below
        table = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    if table.size == 0:
        table = np.empty((0, len(header)))
    if table.shape[1] != len(header):
        raise ValueError(f"its rows have {table.shape[1]} values but its header names {len(header)} columns")
    columns = _csv_columns_by_name(header, len(metadata["joint_names"]), metadata["task"])
    t, angles, v, tau, x, x_ref = (table[:, columns[group]] for group in ("t", "q", "v", "tau", "x", "xref"))
    metadata["task_error"] = table[:, columns["task_error"]][:, 0]
    metadata["infeasible"] = table[:, columns["infeasible"]][:, 0] != 0
    dexterity = {name: table[:, index[0]].copy() for name, index in columns.items() if name in _dexterity_names()}
    margin = table[:, columns[_MARGIN][0]].copy() if _MARGIN in columns else None
    upper = np.array([np.inf if u is None else u for u in metadata.pop("torque_upper")], float)
    lower = np.array([-np.inf if u is None else u for u in metadata.pop("torque_lower")], float)
    return result_type(
        **metadata,
        t=t[:, 0],
        q=angles if robot is None else np.array([robot.configuration(row) for row in angles]).reshape(len(angles), -1),
        joint_angles=angles,
        v=v,
        acceleration=np.full_like(v, np.nan),
        tau=tau,
        x=x,
        x_ref=x_ref,
        jacobian_inverse_condition=np.full(len(t), np.nan),
        torque_upper=upper,
        torque_lower=lower,
        dexterity=dexterity or None,
        stability_margin=margin,
    )


def _dexterity_names() -> tuple[str, ...]:
    from .dexterity import DEXTERITY_COLUMNS

    return DEXTERITY_COLUMNS


def _csv_columns_by_name(header: list[str], n: int, task: str) -> dict[str, list[int]]:
    """Column indices of each group of a run CSV's header, read by name, in any order.

    The contract: ``t``, ``q1..qn``, ``v1..vn``, ``tau1..taun``, ``x1..xm``,
    ``xref1..xrefm`` (m from the task), ``task_error``, ``infeasible``, and
    optionally the dexterity measures by their names.

    Raises:
        InvalidInput: a missing, repeated or unknown column, naming it and the contract.
    """
    from .robot import TASK_DIMENSIONS

    m = TASK_DIMENSIONS.get(task)
    if m is None:
        raise ValueError(f"its sidecar names the task '{task}', not one of {', '.join(TASK_DIMENSIONS)}")
    where = {}
    for index, name in enumerate(header):
        if name in where:
            raise ValueError(f"its header names column '{name}' twice")
        where[name] = index
    groups = _column_groups(n, m)
    optional = {name: [name] for name in (*_dexterity_names(), _MARGIN) if name in where}
    if all(name in where for name in _joint_dynamics_columns(n)):
        # Derived from v and the sidecar's joint dynamics: accepted, not read.
        optional["joint_dynamics"] = _joint_dynamics_columns(n)
    contract = (
        f"t, q1..q{n}, v1..v{n}, tau1..tau{n}, x1..x{m}, xref1..xref{m}, task_error, infeasible "
        f"(then damping1..damping{n} and friction1..friction{n}, dexterity, stability_margin)"
    )
    missing = [name for names in groups.values() for name in names if name not in where]
    if missing:
        raise ValueError(f"its header has no column {', '.join(missing)}; a run of {n} joints has {contract}")
    known = {name for names in (*groups.values(), *optional.values()) for name in names}
    unknown = [name for name in header if name not in known]
    if unknown:
        raise ValueError(
            f"its header has unknown column {', '.join(repr(u) for u in unknown)}; a run of {n} joints has {contract}"
        )
    return {key: [where[name] for name in names] for key, names in {**groups, **optional}.items()}


def json_number(value: float) -> float | None:
    """A float as JSON holds it: None for ±inf and NaN (an unbounded limit)."""
    return float(value) if np.isfinite(value) else None

"""Studies beside the paper's reproduction, each answering one of the questions the paper leaves open.

A study runs on the paper's results and is written into the same folder by
:func:`torqueopt.paper.write_paper`: it is an object with

* ``key``: its entry in ``summary.json``;
* ``write_figures(out_dir) -> list[Path]``: its figures;
* ``summary() -> dict``: its JSON-ready numbers;
* ``markdown(figures) -> str``: its section of ``summary.md``, tables of those numbers.

What the numbers answer is said by the documentation's pages
(docs/discussion/), which read them from the committed JSON
(:mod:`torqueopt.pages`). One package per study, each split by job
(running it, its record, its report, its figures):
:mod:`torqueopt.studies.remedies` (the Discussion's remedies for the
whiplash: a kinematic term in the criterion, linear programming) and
:mod:`torqueopt.studies.local_global` (local against whole-movement
optimisation, the Discussion's last question).
"""

from __future__ import annotations

from pathlib import Path
from typing import Protocol

__all__ = ["Study"]


class Study(Protocol):
    """What :func:`torqueopt.paper.write_paper` needs of a study to write it beside the paper."""

    key: str

    def write_figures(self, out_dir: Path, figure_format: str = "png") -> list[Path]: ...

    def summary(self) -> dict: ...

    def markdown(self, figures: list[str]) -> str: ...

"""Why the stick strip (torqueopt.plots.stick) places its axes by hand: the cost of constrained layout.

A strip of the default eight snapshot panels over a joint-speed plot is
drawn twice, once laid out by matplotlib's constrained layout (a subplot
mosaic) and once with the axes placed by hand as the strip does, and
written to PNG at 150 dpi. The two cases alternate round by round; the
figure is CPU time per strip (``time.process_time``), median and best.

    python benchmarks/bench_stick_layout.py --rounds 5
"""

from __future__ import annotations

import argparse
import io
import time

import numpy as np
from matplotlib.figure import Figure

PANELS = 8
COLUMNS = 5


def _draw_panels(axes) -> None:
    line = np.linspace(0.0, 1.0, 50)
    for ax in axes:
        ax.plot(line, line**2, "-o", ms=3)
        ax.set_aspect("equal")
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.text(0.03, 0.95, "t = 0.000 s", transform=ax.transAxes, va="top")


def _speeds(ax) -> None:
    t = np.linspace(0.0, 2.0, 2000)
    ax.plot(t, np.sin(10.0 * t))


def constrained_strip() -> Figure:
    fig = Figure(figsize=(16, 9), layout="constrained")
    names = [f"p{i}" for i in range(PANELS)]
    rows = [names[i : i + COLUMNS] for i in range(0, PANELS, COLUMNS)]
    mosaic = [row + ["."] * (COLUMNS - len(row)) for row in rows] + [["speed"] * COLUMNS]
    axes = fig.subplot_mosaic(mosaic)
    _draw_panels([axes[name] for name in names])
    _speeds(axes["speed"])
    fig.legend(["arm"], loc="upper center")
    return fig


def strip_by_hand() -> Figure:
    fig = Figure(figsize=(16, 9))
    axes = [fig.add_axes((0.05 + (i % COLUMNS) * 0.19, 0.62 - (i // COLUMNS) * 0.3, 0.17, 0.25)) for i in range(PANELS)]
    _draw_panels(axes)
    _speeds(fig.add_axes((0.05, 0.05, 0.9, 0.2)))
    fig.legend(["arm"], loc="upper center")
    return fig


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    cases = {"constrained layout": constrained_strip, "axes placed by hand": strip_by_hand}
    seconds = {name: [] for name in cases}
    for _ in range(args.rounds):
        for name, make in cases.items():
            start = time.process_time()
            make().savefig(io.BytesIO(), format="png", dpi=150)
            seconds[name].append(time.process_time() - start)
    print("| layout | median CPU [s] | best CPU [s] |")
    print("| --- | ---: | ---: |")
    for name, values in seconds.items():
        print(f"| {name} | {np.median(values):.3f} | {min(values):.3f} |")


if __name__ == "__main__":
    main()

"""Reading a saved matplotlib figure back: its lines by label, its horizontal and vertical marker lines.

The figure tests compare what was drawn with the run it was drawn from;
:func:`tests.conftest.saved_figures` collects the figures as they are saved.
"""

import numpy as np


def labelled(ax, label):
    """The one line of ``ax`` with this legend label."""
    found = [line for line in ax.get_lines() if line.get_label() == label]
    assert len(found) == 1, f"{len(found)} lines labelled {label!r}; labels: {[l.get_label() for l in ax.get_lines()]}"
    return found[0]


def data(ax, label):
    """(x, y) of the line labelled ``label``, as float arrays."""
    line = labelled(ax, label)
    return np.asarray(line.get_xdata(), float), np.asarray(line.get_ydata(), float)


def _spanning(ax, axis):
    """Lines that span the axes along ``axis`` (axhline: x from 0 to 1 in axes coordinates; axvline: y)."""
    found = []
    for line in ax.get_lines():
        x, y = np.asarray(line.get_xdata(), float), np.asarray(line.get_ydata(), float)
        if x.size != 2:
            continue
        across, level = (x, y) if axis == "horizontal" else (y, x)
        if across.tolist() == [0.0, 1.0] and level[0] == level[1]:
            found.append((float(level[0]), line))
    return found


def horizontal_levels(ax):
    """The heights of the lines drawn across ``ax`` (axhline), sorted."""
    return sorted(level for level, _ in _spanning(ax, "horizontal"))


def vertical_marks(ax):
    """{label: time} of the lines drawn up ``ax`` (axvline); unlabelled ones under their matplotlib names."""
    return {line.get_label(): level for level, line in _spanning(ax, "vertical")}


def vertical_times(ax):
    """The times of every vertical line of ``ax`` (axvline), sorted."""
    return sorted(level for level, _ in _spanning(ax, "vertical"))


def errorbar(ax, label):
    """(x, y, low, high) of the error bars labelled ``label``: the points and each bar's lower and upper end."""
    found = [container for container in ax.containers if container.get_label() == label]
    assert len(found) == 1, f"{len(found)} error bars labelled {label!r}"
    points, _, (bars, *_) = found[0].lines
    ends = np.array([segment[:, 1] for segment in bars.get_segments()])
    return np.asarray(points.get_xdata(), float), np.asarray(points.get_ydata(), float), ends[:, 0], ends[:, 1]

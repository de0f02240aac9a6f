r"""The paper's claims as statistics over the atlas, with Wilson 95 % intervals.

For k successes in n trials the Wilson score interval at level
:math:`1 - \alpha` (z = 1.959964 for 95 %) is

.. math::

    \frac{\hat p + \frac{z^2}{2n} \pm z\sqrt{\frac{\hat p(1-\hat p)}{n} + \frac{z^2}{4n^2}}}{1 + \frac{z^2}{n}},
    \qquad \hat p = k/n,

which, unlike the normal approximation, stays inside [0, 1] and is not
empty at k = 0 or k = n. SciPy computes it
(``scipy.stats.binomtest(k, n).proportion_ci(method="wilson")``).

Every claim is computed twice, once for each instability criterion: the
2x-limit rule (column ``unstable``) and the whiplash verdict
(``verdict == "whiplash"``, the 2x-limit rule with the runaway criterion).
"""

from __future__ import annotations

import importlib
import math
import threading
from dataclasses import asdict, dataclass

__all__ = [
    "CONFIDENCE_LEVEL",
    "CRITERIA",
    "Proportion",
    "claims",
    "import_scipy_stats_meanwhile",
    "proportion",
    "unstable_fractions",
    "wilson_interval",
]

#: The confidence level of every interval the atlas reports.
CONFIDENCE_LEVEL = 0.95
#: Instability criteria: column label -> description.
CRITERIA = {
    "unstable": "2x-limit rule (a joint needs more than twice its torque limit)",
    "whiplash": "whiplash verdict (2x-limit rule and a runaway: torque far above pinv's or self-motion energy)",
}


def wilson_interval(successes: int, trials: int, confidence_level: float = CONFIDENCE_LEVEL) -> tuple[float, float]:
    """Wilson score interval (low, high) for ``successes`` out of ``trials``, by SciPy; (nan, nan) when trials = 0."""
    if trials <= 0:
        return math.nan, math.nan
    if not 0 <= successes <= trials:
        raise ValueError(f"successes={successes} must be between 0 and trials={trials}")
    from scipy.stats import binomtest

    interval = binomtest(int(successes), int(trials)).proportion_ci(confidence_level=confidence_level, method="wilson")
    return float(interval.low), float(interval.high)


def import_scipy_stats_meanwhile() -> None:
    """Start importing ``scipy.stats`` on a daemon thread, for a caller that waits on other work first.

    The import takes about 1.6 s (SciPy parses its distributions' docstrings as it loads them), a
    quarter of a small atlas's fixed cost when it follows the sweep; started while the workers compute,
    it is done by the time :func:`wilson_interval` needs it. The atlas starts it once fewer chunks are left
    than workers (:func:`torqueopt.atlas.sweep.run_chunks`): on a machine with as many cores as workers, it
    took 1.3-1.6 s of CPU from them when started with the sweep. Python's import lock makes a later import of
    the module wait for this one to finish, never run twice.
    """
    threading.Thread(
        target=importlib.import_module, args=("scipy.stats",), name="import scipy.stats", daemon=True
    ).start()


@dataclass(frozen=True)
class Proportion:
    """k of n, the fraction and its Wilson 95 % interval."""

    successes: int
    trials: int
    fraction: float
    low: float
    high: float

    def text(self) -> str:
        if not self.trials:
            return "no cases"
        return f"{self.fraction:.1%} ({self.successes}/{self.trials}; 95% CI {self.low:.1%}-{self.high:.1%})"

    def as_dict(self) -> dict:
        return asdict(self)


def proportion(successes: int, trials: int) -> Proportion:
    low, high = wilson_interval(int(successes), int(trials))
    fraction = successes / trials if trials else math.nan
    return Proportion(int(successes), int(trials), fraction, low, high)


def _flags(table, criterion: str):
    """Per row, True when unstable by ``criterion`` ('unstable' or 'whiplash')."""
    if criterion == "unstable":
        return table["unstable"].astype(bool)
    if criterion == "whiplash":
        return table["verdict"] == "whiplash"
    raise ValueError(f"unknown criterion '{criterion}': choose one of {', '.join(CRITERIA)}")


def _wide(table, criterion: str):
    """One row per path, one boolean column per resolver."""
    frame = table.assign(flag=_flags(table, criterion).to_numpy())
    return frame.pivot(index="path", columns="resolver", values="flag")


def unstable_fractions(table, criterion: str = "unstable") -> list[dict]:
    """Per (resolver, duration): the unstable fraction with its interval, in table order."""
    frame = table.assign(flag=_flags(table, criterion).to_numpy())
    out = []
    for resolver in dict.fromkeys(table["resolver"]):
        for duration in sorted(set(table["duration"])):
            rows = frame[(frame["resolver"] == resolver) & (frame["duration"] == duration)]
            share = proportion(int(rows["flag"].sum()), len(rows))
            out.append({"resolver": resolver, "duration": float(duration), **share.as_dict()})
    return out


def claims(table, criterion: str = "unstable") -> list[dict]:
    """The paper's four claims about long paths, each with its figure and whether the atlas bears it out.

    A claim about "long" paths is judged at the longest duration in the
    atlas. ``holds`` is "yes", "no" or "undecided" (the interval allows
    both); the rule is stated with each claim (its ``rule``).
    """
    wide = _wide(table, criterion)
    durations = table.groupby("path")["duration"].first()
    longest = float(durations.max())
    long_paths = durations.index[durations == longest]
    results = []

    def column(name):
        return wide[name] if name in wide.columns else None

    null_space, weighted = column("null-space"), column("weighted-null-space")
    inertia, pinv = column("inertia-pinv"), column("pinv")

    if null_space is not None:
        share = proportion(int(null_space.loc[long_paths].sum()), len(long_paths))
        results.append(
            _claim(
                "nearly any long path led to similar instability problems",
                f"null-space unstable on the {longest:g} s paths",
                share,
                holds=_decide(share.low >= 0.5, share.high < 0.5),
                rule="yes when the interval lies at or above 50 %, no when below",
            )
        )
    if pinv is not None:
        share = proportion(int(pinv.loc[long_paths].sum()), len(long_paths))
        results.append(
            _claim(
                "this rarely happened in the case of the unweighted pseudoinverse algorithm",
                f"pinv unstable on the {longest:g} s paths",
                share,
                holds=_decide(share.high <= 0.10, share.low > 0.10),
                rule="yes when the interval lies at or below 10 %, no when above",
            )
        )
    if null_space is not None and weighted is not None:
        only_weighted = proportion(int((weighted & ~null_space).sum()), len(wide))
        only_null = proportion(int((null_space & ~weighted).sum()), len(wide))
        results.append(
            _claim(
                "there were even movements where the instability was shown only by the weighted case",
                "weighted-null-space unstable and null-space not, all paths",
                only_weighted,
                holds=_decide(only_weighted.successes > 0, False),
                rule="yes with at least one such path; undecided with none (not found here)",
            )
        )
        results.append(
            _claim(
                "although the reverse was not found",
                "null-space unstable and weighted-null-space not, all paths",
                only_null,
                holds=_decide(only_null.successes == 0, only_null.successes > 0),
                rule="yes with no such path; no with any (the paper found none)",
            )
        )
    if null_space is not None and inertia is not None:
        given = null_space.astype(bool)
        share = proportion(int((inertia & given).sum()), int(given.sum()))
        results.append(
            _claim(
                "whenever the null-space algorithm was unstable, the inertia-weighted pseudoinverse algorithm was "
                "unstable as well (in most of the trajectories studied)",
                "P(inertia-pinv unstable | null-space unstable), all paths",
                share,
                holds=_decide(share.trials > 0 and share.low > 0.5, share.trials > 0 and share.high < 0.5),
                rule="yes when the interval lies above 50 % ('most'), no when below",
            )
        )
    return results


def _decide(confirmed: bool, refuted: bool) -> str:
    """'yes', 'no', or 'undecided' when the interval allows both."""
    return "yes" if confirmed else "no" if refuted else "undecided"


def _claim(words: str, figure: str, share: Proportion, holds: str, rule: str) -> dict:
    return {"paper": words, "figure": figure, **share.as_dict(), "text": share.text(), "holds": holds, "rule": rule}

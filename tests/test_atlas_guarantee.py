"""The bar of a resolver with a stability guarantee (torqueopt.atlas.guarantee), against hand-counted tables."""

import json
import math

import numpy as np
import pytest

from torqueopt.atlas.guarantee import guarantee_markdown, guarantee_summary, least_paths, main
from torqueopt.atlas.stats import wilson_interval

pandas = pytest.importorskip("pandas")

CONFIG = {"resolvers": [{"name": "pinv"}, {"name": "energy-bounded-torque", "options": {"energy_limit": 2.0}}]}


def _table():
    """Six paths, two durations. pinv: (verdict, peak); the resolver: (verdict, peak, torque_vs_pinv, E_N peak,
    infeasible steps, tip error)."""
    pinv = [
        ("stable", 0.8),  # 0: handled
        ("stable", 0.9),  # 1: handled
        ("stable", 1.5),  # 2: over a limit
        ("whiplash", 3.0),  # 3: over
        ("lost path", 0.7),  # 4: within its limits, not handled
        ("stable", 0.5),  # 5: handled
    ]
    resolver = [
        ("stable", 0.7, 0.875, 1.0, 0, 1e-5),
        ("lost path", 1.0, 1.1, 2.001, 10, 0.3),  # E_N 0.05 % over: not counted above E_max
        ("stable", 1.0, 0.6, 2.5, 4, 1e-4),  # 25 % over E_max
        ("lost path", 0.9, 0.3, 2.03, 7, 0.2),  # 1.5 % over
        ("stable", 1.2, 1.7, 0.5, 0, 1e-5),  # over a limit where pinv is within
        ("lost path", 0.4, 0.8, 0.1, 0, 0.01),
    ]
    rows = []
    for path, ((pv, pp), (v, peak, ratio, energy, infeasible, tip)) in enumerate(zip(pinv, resolver)):
        duration = 0.5 if path < 3 else 1.0
        common = {"path": path, "duration": duration, "steps": int(duration * 1000)}
        rows.append({**common, "resolver": "pinv", "verdict": pv, "peak_torque_ratio": pp, "torque_vs_pinv": 1.0,
                     "peak_self_motion_energy": 0.0, "infeasible_steps": 0, "max_tip_error": 1e-6})  # fmt: skip
        rows.append({**common, "resolver": "energy-bounded-torque", "verdict": v, "peak_torque_ratio": peak,
                     "torque_vs_pinv": ratio, "peak_self_motion_energy": energy, "infeasible_steps": infeasible,
                     "max_tip_error": tip})  # fmt: skip
    return pandas.DataFrame(rows)


def test_the_bar_counted_by_hand():
    summary = guarantee_summary(_table(), CONFIG)
    every = summary["all"]
    assert every["runs"] == 6 and every["whiplash"]["successes"] == 0 and every["pinv_whiplash"] == 1
    assert every["whiplash"]["high"] == pytest.approx(wilson_interval(0, 6)[1])
    # pinv within its limits on 0, 1, 4, 5; the resolver within them on 0, 1, 5 of those (1.2 on path 4).
    assert every["pinv_within_torque_limits"] == 4 and every["within_torque_limits_where_pinv_is"] == 3
    assert every["largest_peak_where_pinv_within"] == 1.2
    assert every["pinv_handles"] == 3 and every["within_torque_limits_where_pinv_handles"] == 3
    assert every["torque_vs_pinv"]["median"] == pytest.approx(np.median([0.875, 1.1, 0.6, 0.3, 1.7, 0.8]))
    assert every["torque_vs_pinv_where_pinv_handles"]["median"] == pytest.approx(0.875)
    assert every["torque_vs_pinv_where_pinv_over"]["median"] == pytest.approx(0.45)
    assert every["lost_path"] == 3 and every["lost_path_where_pinv_handles"] == 2 and every["pinv_lost_path"] == 1
    assert every["lost_path_with_infeasible_steps"] == 2 and every["kept_path"] == 3
    assert every["infeasible_runs"] == 3 and every["infeasible_steps"] == 21 and every["steps"] == 4500
    assert every["energy_limit"] == 2.0 and every["largest_energy"] == 2.5
    assert every["above_energy_limit"] == 2 and every["above_energy_limit_1pc"] == 2
    assert every["above_energy_limit_with_infeasible_steps"] == 2
    short, long = summary["durations"]["0.5"], summary["durations"]["1"]
    assert short["runs"] == long["runs"] == 3 and short["lost_path"] == 1 and long["lost_path"] == 2
    assert short["torque_vs_pinv"]["median"] == pytest.approx(0.875)
    # Not met: six paths cannot bound the whip rate under 0.1 %, one run passes a limit pinv keeps, median 0.8375.
    assert summary["bar"] == {
        "no_whip": False,
        "within_torque_limits_where_pinv_is": False,
        "saves_torque": True,
        "met": False,
    }
    text = "\n".join(guarantee_markdown(summary))
    assert "| 3 of 4 (largest peak \\|τ\\|/limit there 1.2000)" in text and "| 1 s | 3 |" in text


def test_least_paths_is_where_the_wilson_bound_falls_under_the_bar():
    n = least_paths(0.001)
    assert n == 3838
    assert wilson_interval(0, n)[1] < 0.001 <= wilson_interval(0, n - 1)[1]
    assert wilson_interval(0, least_paths(0.01))[1] < 0.01 <= wilson_interval(0, least_paths(0.01) - 1)[1]


def test_the_command_writes_guarantee_json(tmp_path, capsys):
    _table().to_parquet(tmp_path / "results.parquet", index=False)
    (tmp_path / "atlas-config.json").write_text(json.dumps(CONFIG))
    assert main([str(tmp_path)]) == 0
    written = json.loads((tmp_path / "guarantee.json").read_text())
    assert written["all"]["lost_path"] == 3 and written["bar"]["met"] is False
    assert "| the bar | measured | |" in capsys.readouterr().out
    assert main([]) == 2
    with pytest.raises(ValueError, match="rows of both 'minmax-torque' and 'pinv'"):
        guarantee_summary(_table(), CONFIG, "minmax-torque")
    assert math.isnan(guarantee_summary(_table(), {}, "energy-bounded-torque")["all"]["energy_limit"])

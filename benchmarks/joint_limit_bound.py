"""The bounded resolvers' joint-limit bound before and after a change, on samples of the arms' committed atlases.

Reads the rows ``house_numbers.py committed --save DIR`` wrote for the same seeded sample of paths with two
versions of the code, and prints, per atlas and per resolver that keeps the joint limits, how many paths give up
the task (a task-acceleration shortfall or an infeasible step), how many leave a position limit, and how many are
newly outside one. Run, one after the other, on each version of the code:

    python benchmarks/house_numbers.py committed --paths-per-atlas 200 --save BEFORE \\
        xarm7-bounded panda-bounded baxter-bounded tiago-bounded
    python benchmarks/house_numbers.py committed --paths-per-atlas 200 --save AFTER \\
        xarm7-bounded panda-bounded baxter-bounded tiago-bounded
    python benchmarks/joint_limit_bound.py BEFORE AFTER
"""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

#: A shortfall below this [m/s²] is round-off of a realised task, not a task given up.
SHORTFALL = 1e-6


def gave_up(rows: pd.DataFrame) -> pd.Series:
    return (rows["max_task_error"] > SHORTFALL) | (rows["infeasible_steps"] > 0)


def outside(rows: pd.DataFrame) -> pd.Series:
    return rows["first_position_limit_violation"].notna()


def table(before_folder: Path, after_folder: Path) -> list[dict]:
    found = []
    for after_file in sorted(after_folder.glob("*.parquet")):
        before = pd.read_parquet(before_folder / after_file.name).set_index(["path", "resolver"])
        after = pd.read_parquet(after_file).set_index(["path", "resolver"])
        for resolver in sorted(after.index.get_level_values("resolver").unique()):
            if "joint_limits=off" in resolver or not any(n in resolver for n in ("bounded", "minmax")):
                continue
            b, a = before.xs(resolver, level="resolver"), after.xs(resolver, level="resolver")
            b = b.loc[a.index]
            found.append(
                {
                    "atlas": after_file.stem.replace("--", "/"),
                    "resolver": resolver,
                    "paths": len(a),
                    "gives up the task, before": int(gave_up(b).sum()),
                    "after": int(gave_up(a).sum()),
                    "outside a position limit, before": int(outside(b).sum()),
                    "after ": int(outside(a).sum()),
                    "newly outside": int((outside(a) & ~outside(b)).sum()),
                }
            )
    return found


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print(__doc__)
        return 2
    rows = table(Path(argv[0]), Path(argv[1]))
    if not rows:
        print("no saved rows of a bounded resolver with joint limits found")
        return 1
    print("| " + " | ".join(rows[0]) + " |")
    print("|" + "---|" * len(rows[0]))
    for row in rows:
        print("| " + " | ".join(str(value) for value in row.values()) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

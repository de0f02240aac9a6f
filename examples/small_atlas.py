"""A small stability atlas from Python: how often does each resolver whip on random lines of the paper's arm?

``torqueopt.atlas.run_atlas`` draws a seeded population of straight lines
(start configurations uniform in the joint ranges, directions uniform on the
circle, kept when the line stays within reach and the start is not
near-singular), runs every resolver on each, judges every run and writes
``results.parquet``, ``atlas.md`` and ``atlas.json`` into ``out``. This one
is small and runs in the calling process (``workers=0``: no Dask cluster);
the atlas of the documentation is the same call with ``paths=250`` and eight
resolvers. Needs the atlas extra (``pip install '.[atlas]'``).

Run: python examples/small_atlas.py [--paths 20] [--out atlas-small]
"""

import argparse
import tempfile

from torqueopt.atlas import run_atlas
from torqueopt.atlas.stats import wilson_interval

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
parser.add_argument("--paths", type=int, default=20, help="movements per duration (default 20)")
parser.add_argument("--out", default=None, help="folder for the atlas's files (default: a temporary one)")
arguments = parser.parse_args()

with tempfile.TemporaryDirectory() as scratch:
    atlas = run_atlas(
        "planar3",
        paths=arguments.paths,
        durations=(1.0, 2.0),
        resolvers=("pinv", "null-space"),
        out=arguments.out or scratch,
        seed=2026,
        workers=0,
        progress=False,
        figures=False,
    )
    table = atlas.table  # one row per movement and resolver (a pandas DataFrame)
    print(f"{len(table)} runs; whiplash verdicts with Wilson 95 % intervals:")
    for (resolver, duration), runs in table.groupby(["resolver", "duration"]):
        whips = int((runs["verdict"] == "whiplash").sum())
        low, high = wilson_interval(whips, len(runs))
        print(f"{resolver:>12} T = {duration:g} s: {whips:3d}/{len(runs)} whip, 95 % CI [{low:.0%}, {high:.0%}]")

"""Every CAD file of a folder through several jobs at once, with `trimsurf.batch` (dask.distributed).

    python examples/batch_folder.py models/ [--jobs tessellate view]

Runs ``trimsurf.batch.run(inputs, jobs=[...], client=None)`` (a local
cluster) and prints one line per part. Needs the ``trimsurf.batch`` package;
without it the script says so and exits 2.
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
from pathlib import Path


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path, help="folder of STEP, IGES or BREP files")
    parser.add_argument("--jobs", nargs="+", default=["tessellate"], help="jobs per part (default: tessellate)")
    args = parser.parse_args(argv)
    if importlib.util.find_spec("trimsurf.batch") is None:
        print("batch_folder: trimsurf.batch is not installed in this trimsurf", file=sys.stderr)
        return 2
    import trimsurf.io as tio
    from trimsurf.batch import run

    inputs = sorted(p for p in args.folder.iterdir() if p.suffix.lower() in tio.CAD_SUFFIXES)
    if not inputs:
        print(f"batch_folder: no CAD file in {args.folder}", file=sys.stderr)
        return 2
    results = run(inputs, jobs=list(args.jobs), client=None)
    rows = results if isinstance(results, list) else getattr(results, "rows", results)
    for row in rows if isinstance(rows, (list, tuple)) else [rows]:
        print(row)
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""`quality.interpolation_bound.span_bounds` over every face's surface of a file: the compiled kernel
(`span_bounds`) against the numpy version it replaced (`_span_bounds_numpy`), alternating, best of 7, CPU
(issue 17, item 2; session 28).

Usage: python benchmarks/span_bounds_micro.py [FILE ...]   (default: U_Joint and featuretype)
"""

from __future__ import annotations

import gc
import sys
import time
from pathlib import Path

from trimsurf.io import read_shell
from trimsurf.quality import interpolation_bound as ib

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "cad"


def main() -> None:
    names = sys.argv[1:] or ["gmsh__U_Joint_2.stp", "trimesh__featuretype.STEP"]
    for n in names:
        surfaces = [f.surface for f in read_shell(DATA / n).faces]
        for s in surfaces[:2]:
            ib.span_bounds(s)
        best = {}
        for _ in range(7):
            for name, fn in (("numpy", ib._span_bounds_numpy), ("kernel", ib.span_bounds)):
                gc.collect()
                c = time.process_time()
                for s in surfaces:
                    fn(s)
                best[name] = min(best.get(name, 1e9), time.process_time() - c)
        print(f"{n}: {len(surfaces)} surfaces, numpy {best['numpy'] * 1e3:.2f} ms, "
              f"kernel {best['kernel'] * 1e3:.2f} ms, ratio {best['kernel'] / best['numpy']:.3f}")


if __name__ == "__main__":
    main()

"""The faces' iso-line placements alone (issue 17): capture the `equidistributed_kernel` calls `face._place_axis`
makes during one tessellate_shell per model, then replay them (best of N per call, summed; perf counter) and check
the outputs bit for bit against the capture. Run it with each tree's src (old and new one after the other,
a few times: the machine is noisy).

    PYTHONPATH=src python benchmarks/place_replay.py capture --models featuretype,t20,screw,U_Joint [--mode tol]
    PYTHONPATH=src python benchmarks/place_replay.py replay --models ... --runs 20
    PYTHONPATH=OLD/src python benchmarks/place_replay.py replay --models ... --runs 20     (the before column)

(Not in-process: a tree's `_line_kernels` loaded under another module name would write numba cache entries
next to that tree's source that its own module cannot load.)

The arguments are copied before each call: the kernel writes the family's record of its start (cf).
"""

from __future__ import annotations

import argparse
import pickle
import time
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "cad"
if not DATA.exists():
    DATA = Path("/work/shared/data/cad")


def _cp(a):
    return [x.copy() if isinstance(x, np.ndarray) else x for x in a]


def _same(res, ref) -> bool:
    return all(np.shape(o) == np.shape(r) and np.asarray(o).tobytes() == np.asarray(r).tobytes()
               for o, r in zip(res, ref))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("what", choices=["capture", "replay"])
    ap.add_argument("--models", default="featuretype,t20,screw,U_Joint")
    ap.add_argument("--mode", choices=["tol", "paper"], default="tol")
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--dir", default="/tmp/place_replay")
    args = ap.parse_args(argv)
    from trimsurf.tessellate import _line_kernels as lk
    from trimsurf.tessellate import face as F

    out = Path(args.dir)
    out.mkdir(parents=True, exist_ok=True)
    for key in args.models.split(","):
        path = out / f"{key}_{args.mode}.pkl"
        if args.what == "capture":
            from trimsurf.io import read_shell
            from trimsurf.tessellate import tessellate_shell

            name = next(p for p in sorted(DATA.iterdir()) if key in p.name)
            shell = read_shell(name)
            d = shell.diagonal()
            calls, orig = [], F.equidistributed_kernel

            def cap(*a, _orig=orig, _calls=calls):
                a2 = _cp(a)
                res = _orig(*a)
                _calls.append((a2, [np.copy(o) for o in res]))
                return res

            F.equidistributed_kernel = cap
            try:
                tessellate_shell(shell, tolerance=1e-3 * d, max_edge=d if args.mode == "tol" else 3e-2 * d,
                                 measure=False)
            finally:
                F.equidistributed_kernel = orig
            path.write_bytes(pickle.dumps(calls))
            print(f"{key}: {len(calls)} calls captured -> {path}")
            continue
        calls = pickle.loads(path.read_bytes())
        kernel = lk.equidistributed_kernel
        same = True
        for a, ref in calls:
            same &= _same(kernel(*_cp(a)), ref)
        best = np.full(len(calls), np.inf)
        for _ in range(args.runs):
            for i, (a, _) in enumerate(calls):
                c = _cp(a)
                t = time.perf_counter()
                kernel(*c)
                best[i] = min(best[i], time.perf_counter() - t)
        print(f"{key:12s} {args.mode:5s} calls {len(calls):4d}  best per call, summed {best.sum() * 1e3:7.2f} ms  "
              f"identical {same}")


if __name__ == "__main__":
    main()

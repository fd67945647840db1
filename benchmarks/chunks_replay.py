"""discretize_chunks_kernel alone (issue 17): capture its arguments and outputs during one tessellate_shell per
model, then replay the calls (best of N, process CPU) and check the outputs bit for bit against the capture.

    PYTHONPATH=OLD/src python benchmarks/chunks_replay.py capture --models featuretype,U_Joint [--mode tol]
    PYTHONPATH=src NUMBA_CACHE_DIR=$(mktemp -d) python benchmarks/chunks_replay.py replay --models ... --runs 30
    PYTHONPATH=OLD/src python benchmarks/chunks_replay.py replay ...          (the before column)

Use a fresh NUMBA_CACHE_DIR after editing `_line_kernels.py` alone: numba's cache index of
discretize_chunks_kernel keys on `_chunk_kernels.py` only, so a stale cache replays the old helpers' code.
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


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("what", choices=["capture", "replay"])
    ap.add_argument("--models", default="featuretype,t20,screw,U_Joint")
    ap.add_argument("--mode", choices=["tol", "paper"], default="tol")
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--dir", default="/tmp/chunks_replay")
    args = ap.parse_args(argv)
    from trimsurf.tessellate import _chunk_kernels as ck

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
            calls, orig = [], ck.discretize_chunks_kernel

            def cap(*a, _orig=orig, _calls=calls):
                a2 = [x.copy() if isinstance(x, np.ndarray) else x for x in a]
                res = _orig(*a)
                _calls.append((a2, [o.copy() for o in res]))
                return res

            ck.discretize_chunks_kernel = cap
            try:
                tessellate_shell(shell, tolerance=1e-3 * d, max_edge=d if args.mode == "tol" else 3e-2 * d, measure=False)
            finally:
                ck.discretize_chunks_kernel = orig
            path.write_bytes(pickle.dumps(calls))
            print(f"{key}: {len(calls)} calls captured -> {path}")
            continue
        calls = pickle.loads(path.read_bytes())
        same = True
        for a, ref in calls:
            res = ck.discretize_chunks_kernel(*[x.copy() if isinstance(x, np.ndarray) else x for x in a])
            same &= all(o.shape == r.shape and o.tobytes() == r.tobytes() for o, r in zip(res, ref))
        best = np.inf
        for _ in range(args.runs):
            copies = [[x.copy() if isinstance(x, np.ndarray) else x for x in a] for a, _ in calls]
            t = time.process_time()
            for a in copies:
                ck.discretize_chunks_kernel(*a)
            best = min(best, time.process_time() - t)
        print(f"{key:12s} {args.mode:5s} calls {len(calls):3d}  best {best * 1e3:7.2f} ms  identical {same}")


if __name__ == "__main__":
    main()

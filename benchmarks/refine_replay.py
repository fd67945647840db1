"""refine_cells_kernel alone (issue 17): capture its arguments and outputs during one tessellate_shell per model,
then replay the calls (best of N, process CPU, per call the best of the runs summed) and check the outputs bit
for bit against the capture (the cache's arrays up to their used rows, the hash tables' used entries, the
grids, status, rounds, the first grid's maxima, the rows).

    PYTHONPATH=OLD/src python benchmarks/refine_replay.py capture --models featuretype,U_Joint [--mode tol]
    PYTHONPATH=src NUMBA_CACHE_DIR=$(mktemp -d) python benchmarks/refine_replay.py replay --models ... --runs 20
    PYTHONPATH=OLD/src python benchmarks/refine_replay.py replay ...          (the before column)

`replay --stats` prints per model the cells checked, the new cells and the surface evaluations by kind
(a tree with `_line_kernels.EVAL_COUNTS`, see there).
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


def _copy(a):
    return [x.copy() if isinstance(x, np.ndarray) else x for x in a]


def _outputs(res) -> list:
    """The outputs that must be the same: the cache's arrays up to their used rows (n), the rest as returned."""
    (hk_u, he_u, hk_v, he_v, table, uv, p, d, devs, bounds, n, us, vs, status, rounds, dev0, diag0, rows) = res
    n = int(n)
    ids = [np.sort(he[he[:, 0] >= 0, 0]) for he in (he_u, he_v)]
    keys = [hk[np.argsort(he[:, 0])][(he[np.argsort(he[:, 0]), 0] >= 0)] for hk, he in ((hk_u, he_u), (hk_v, he_v))]
    used = table[:max(1, table.shape[0]), :]
    return [*ids, *keys, used[used >= 0], uv[:n], p[:n], d[:n], devs[:n], bounds[:n], np.int64(n), us, vs,
            np.int64(status), np.int64(rounds), np.float64(dev0), np.float64(diag0), rows]


def _same(a, b) -> bool:
    return all(np.asarray(x).shape == np.asarray(y).shape and np.asarray(x).tobytes() == np.asarray(y).tobytes()
               for x, y in zip(a, b))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("what", choices=["capture", "replay"])
    ap.add_argument("--models", default="featuretype,t20,screw,U_Joint")
    ap.add_argument("--mode", choices=["tol", "paper"], default="tol")
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--dir", default="/tmp/refine_replay")
    ap.add_argument("--stats", action="store_true")
    args = ap.parse_args(argv)
    from trimsurf.tessellate import face as face_mod
    from trimsurf.tessellate import _line_kernels as lk

    kernel = face_mod.refine_cells_kernel
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
            calls = []

            def cap(*a, _calls=calls):
                a2 = _copy(a)
                res = kernel(*a)
                _calls.append((a2, [o.copy() if isinstance(o, np.ndarray) else o for o in _outputs(res)]))
                return res

            face_mod.refine_cells_kernel = cap
            try:
                tessellate_shell(shell, tolerance=1e-3 * d, max_edge=d if args.mode == "tol" else 3e-2 * d,
                                 measure=False)
            finally:
                face_mod.refine_cells_kernel = kernel
            path.write_bytes(pickle.dumps(calls))
            print(f"{key}: {len(calls)} calls captured -> {path}")
            continue
        calls = pickle.loads(path.read_bytes())
        same = True
        counts = getattr(lk, "EVAL_COUNTS", None)
        if counts is not None:
            counts[:] = 0
        for a, ref in calls:
            same &= _same(_outputs(kernel(*_copy(a))), ref)
        if args.stats and counts is not None:
            print(f"{key:12s} {args.mode:5s} evaluations: " + " ".join(f"{int(c)}" for c in counts))
        best = np.full(len(calls), np.inf)
        for _ in range(args.runs):
            copies = [_copy(a) for a, _ in calls]
            for i, a in enumerate(copies):
                t = time.process_time()
                kernel(*a)
                best[i] = min(best[i], time.process_time() - t)
        tot = np.inf
        for _ in range(max(3, args.runs // 4)):
            copies = [_copy(a) for a, _ in calls]
            t = time.process_time()
            for a in copies:
                kernel(*a)
            tot = min(tot, time.process_time() - t)
        print(f"{key:12s} {args.mode:5s} calls {len(calls):3d}  sum of per-call best {best.sum() * 1e3:7.2f} ms  "
              f"best total {tot * 1e3:7.2f} ms  identical {same}", flush=True)


if __name__ == "__main__":
    main()

"""The faces' iso-line placements alone (issue 17): capture the `equidistributed_kernel` calls `face._place_axis`
makes during one tessellate_shell per model, then replay them (best of N per call, summed; perf counter) and check
the outputs bit for bit against the capture; with ``--reference OLD/src`` the reference tree's
`_line_kernels.equidistributed_kernel` runs on the same calls, call by call interleaved with this one.

    PYTHONPATH=src python benchmarks/place_replay.py capture --models featuretype,t20,screw,U_Joint [--mode tol]
    PYTHONPATH=src NUMBA_CACHE_DIR=$(mktemp -d) python benchmarks/place_replay.py replay --models ... --runs 20 \
        [--reference /tmp/main28/src]

The arguments are copied before each call: the kernel writes the family's record of its start (cf).
"""

from __future__ import annotations

import argparse
import importlib.util
import pickle
import sys
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


def _reference_kernel(src: str):
    """`equidistributed_kernel` of the tree at src (its `_line_kernels` loaded as a separate module)."""
    path = Path(src) / "trimsurf" / "tessellate" / "_line_kernels.py"
    spec = importlib.util.spec_from_file_location("trimsurf.tessellate._line_kernels_ref", path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod.equidistributed_kernel


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("what", choices=["capture", "replay"])
    ap.add_argument("--models", default="featuretype,t20,screw,U_Joint")
    ap.add_argument("--mode", choices=["tol", "paper"], default="tol")
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--dir", default="/tmp/place_replay")
    ap.add_argument("--reference", default=None, help="another tree's src: its kernel on the same calls")
    args = ap.parse_args(argv)
    from trimsurf.tessellate import _line_kernels as lk
    from trimsurf.tessellate import face as F

    out = Path(args.dir)
    out.mkdir(parents=True, exist_ok=True)
    ref_kernel = _reference_kernel(args.reference) if args.reference else None
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
        kernels = [lk.equidistributed_kernel] + ([ref_kernel] if ref_kernel else [])
        same = [True] * len(kernels)
        for a, ref in calls:
            for q, k in enumerate(kernels):
                same[q] &= _same(k(*_cp(a)), ref)
        best = np.full((len(kernels), len(calls)), np.inf)
        for _ in range(args.runs):
            for i, (a, _) in enumerate(calls):
                for q, k in enumerate(kernels):
                    c = _cp(a)
                    t = time.perf_counter()
                    k(*c)
                    best[q, i] = min(best[q, i], time.perf_counter() - t)
        tot = best.sum(axis=1) * 1e3
        line = f"{key:12s} {args.mode:5s} calls {len(calls):4d}  new {tot[0]:7.2f} ms  identical {same[0]}"
        if ref_kernel:
            line += f"  | reference {tot[1]:7.2f} ms  identical {same[1]}  new/ref {tot[0] / tot[1]:.3f}"
        print(line)


if __name__ == "__main__":
    main()

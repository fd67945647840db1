"""One kernel's calls replayed under one or two source trees (issue 17): capture what a compiled kernel (or any
trimsurf function the meshing calls from Python) is given while the shared models are meshed, then replay it.

    python benchmarks/kernel_replay.py capture refine --src /tmp/main29/src [--models a,b] [--modes tol,paper]
    python benchmarks/kernel_replay.py replay refine --src /tmp/main29/src --src src [--runs 20] [--rounds 2]
    python benchmarks/kernel_replay.py replay span_bounds --src src [--use MODULE:FUNCTION]   (another function,
        e.g. trimsurf.quality.interpolation_bound:_span_bounds_numpy, given the captured calls)

KERNEL is a name of ENTRIES below (refine, place, chunks, loop_polylines, span_bounds, mesh_faces, seams =
reduce_seams, clean_pslg) or `module:function`; a kernel called only from compiled code (cell_surface_kernel, from
refine_cells_kernel) is timed through its compiled caller. A model and mode without a call (clean_pslg runs only
for the faces whose constraint graph `_domain_prepare_kernel` cannot hand to Triangle at once) is listed as such
and left out of the ratios.

capture: per model (a part of a file name in ../shared/data/cad) and mode (tolerance 1e-3 of the diagonal, max
edge: tol = the diagonal, paper = 3 % of it) one warm `tessellate_shell` (with the measurement where ENTRIES or
`--measure` say), then one of a fresh copy of the shell during which every trimsurf module's name for the kernel
records each call's arguments (pickled at the call; the arrays it writes into as they were before), outputs and
the arrays it wrote into: DIR/KERNEL/MODEL_MODE.pkl.

replay: each call once, its outputs and written arguments compared bit for bit with the capture's (`same`),
then `--runs` times with fresh copies of the arrays it writes into: `per-call` = the sum over the calls of each one's
best (the lesser of wall and process CPU time: the wall clock is finer for a short call, CPU time leaves out the
waits of a long one on a loaded machine), `total` = the best of max(3, runs // 4) passes over all calls (process
CPU). Without `--src` in this process (the trimsurf on PYTHONPATH). With `--src` each tree in a child process
with it first on PYTHONPATH and its own fresh NUMBA_CACHE_DIR (numba's cache index of a kernel keys on its own
file only: a stale cache replays old helpers), the trees one after the other (old first), `--rounds` times, best
of the rounds; the table gives the ratios last tree / first tree and their geometric mean. A capture replays
under any tree whose kernel takes the same arguments (pickled objects load with that tree's classes).
"""

from __future__ import annotations

import argparse
import dataclasses
import gc
import importlib
import json
import os
import pickle
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "cad"
if not DATA.exists():
    DATA = Path("/work/shared/data/cad")


def _refine_outputs(res) -> list:
    """refine_cells_kernel's outputs that must be the same: the cache's arrays up to their used rows (n), the hash
    tables' used entries, the rest as returned (the rows past n are left uninitialized)."""
    (hk_u, he_u, hk_v, he_v, table, uv, p, d, devs, bounds, n, us, vs, status, rounds, dev0, diag0, rows) = res
    n = int(n)
    ids = [np.sort(he[he[:, 0] >= 0, 0]) for he in (he_u, he_v)]
    keys = [hk[np.argsort(he[:, 0])][(he[np.argsort(he[:, 0]), 0] >= 0)] for hk, he in ((hk_u, he_u), (hk_v, he_v))]
    used = table[:max(1, table.shape[0]), :]
    return [*ids, *keys, used[used >= 0], uv[:n], p[:n], d[:n], devs[:n], bounds[:n], np.int64(n), us, vs,
            np.int64(status), np.int64(rounds), np.float64(dev0), np.float64(diag0), rows]


#: name -> (module:function, measure during the capture, the outputs to compare (None: all, flattened))
ENTRIES = {
    "refine": ("trimsurf.tessellate._line_kernels:refine_cells_kernel", False, _refine_outputs),
    "place": ("trimsurf.tessellate._line_kernels:equidistributed_kernel", False, None),
    "chunks": ("trimsurf.tessellate._chunk_kernels:discretize_chunks_kernel", False, None),
    "loop_polylines": ("trimsurf.geom._pcurve_kernels:loop_polylines_kernel", True, None),
    "span_bounds": ("trimsurf.quality.interpolation_bound:span_bounds", True, None),
    "mesh_faces": ("trimsurf.tessellate.face:mesh_face_from_chunks", False, None),
    "seams": ("trimsurf.tessellate.seams:reduce_seams", False, None),
    "clean_pslg": ("trimsurf.tessellate.pslg:clean_pslg", False, None),
}
MODES = {"tol": 1.0, "paper": 3e-2}      # max edge / diagonal


def _flat(x) -> list:
    """The arrays (and scalars as 0-d arrays) of a call's outputs, in order, for bit comparison (objects by their
    fields; what has no bits, e.g. a function, left out)."""
    if x is None:
        return []
    if isinstance(x, (tuple, list)):
        return [a for v in x for a in _flat(v)]
    if isinstance(x, dict):
        return [a for k in sorted(x) for a in _flat(x[k])]
    if dataclasses.is_dataclass(x):
        return _flat([getattr(x, f.name) for f in dataclasses.fields(x)])
    if hasattr(x, "__dict__"):
        return _flat(vars(x))
    a = np.array(x, copy=True)
    return [] if a.dtype == object else [a]


def _copy(args, only=None) -> list:
    """The arguments with their arrays copied (only those at the indices `only` if given)."""
    return [a.copy() if isinstance(a, np.ndarray) and (only is None or i in only) else a for i, a in enumerate(args)]


def _same(a: list, b: list) -> bool:
    return len(a) == len(b) and all(np.shape(x) == np.shape(y) and np.asarray(x).dtype == np.asarray(y).dtype
                                    and np.asarray(x).tobytes() == np.asarray(y).tobytes() for x, y in zip(a, b))


def _resolve(kernel: str):
    """(module, function name, measure, outputs) of a name of ENTRIES or a `module:function`."""
    spec, measure, outputs = ENTRIES.get(kernel, (kernel, False, None))
    mod, _, name = spec.partition(":")
    return importlib.import_module(mod), name, measure, outputs or _flat


def _models(keys: str) -> list[Path]:
    files = sorted(p for p in DATA.iterdir() if p.suffix.lower() in (".step", ".stp", ".iges", ".igs"))
    return [next(p for p in files if k in p.name) for k in keys.split(",")]


def capture(args) -> None:
    from trimsurf.io import read_shell
    from trimsurf.tessellate import tessellate_shell

    mod, name, measure, outputs = _resolve(args.kernel)
    measure = measure or args.measure
    out = Path(args.dir) / args.kernel.replace(":", "_")
    out.mkdir(parents=True, exist_ok=True)
    for path, key in zip(_models(args.models), args.models.split(",")):
        shell = read_shell(path)
        d = shell.diagonal()
        for mode in args.modes.split(","):
            kw = dict(tolerance=1e-3 * d, max_edge=MODES[mode] * d, measure=measure)
            tessellate_shell(read_shell(path), **kw)     # warm: everything imported and compiled before the swap
            real, calls = getattr(mod, name), []

            def rec(*a, _real=real, _calls=calls, **k):
                before = _copy(a)
                res = _real(*a, **k)
                wrote = [i for i, (x, b) in enumerate(zip(a, before))
                         if isinstance(x, np.ndarray) and not _same([x], [b])]
                # pickled now, as they were; the arguments not written into as themselves (caches keyed by identity)
                call = pickle.dumps(([before[i] if i in wrote else x for i, x in enumerate(a)], k))
                _calls.append((call, wrote, [np.copy(o) for o in outputs(res)] + [a[i].copy() for i in wrote]))
                return res

            spots = [(m, v) for m in list(sys.modules.values()) if getattr(m, "__name__", "").startswith("trimsurf")
                     for v, f in list(vars(m).items()) if f is real]
            for m, v in spots:
                setattr(m, v, rec)
            try:
                tessellate_shell(shell, **kw)
            finally:
                for m, v in spots:
                    setattr(m, v, real)
            dest = out / f"{key}_{mode}.pkl"
            dest.write_bytes(pickle.dumps(calls))
            print(f"{key}: {len(calls)} calls captured -> {dest}", flush=True)


def replay(args) -> dict:
    """{model_mode: {calls, per_call, total (s), same}} in this process; printed unless --json."""
    mod, name, _, outputs = _resolve(args.kernel)
    if args.use:
        mod, _, name = args.use.partition(":")
        mod = importlib.import_module(mod)
    kernel = getattr(mod, name)
    res = {}
    for key in args.models.split(","):
        for mode in args.modes.split(","):
            path = Path(args.dir) / args.kernel.replace(":", "_") / f"{key}_{mode}.pkl"
            calls = [(*pickle.loads(call), wrote, ref) for call, wrote, ref in pickle.loads(path.read_bytes())]
            same = True
            for a, k, wrote, ref in calls:
                c = _copy(a, wrote)
                same &= _same(outputs(kernel(*c, **k)) + [c[i] for i in wrote], ref)
            gc.disable()
            best = np.full(len(calls), np.inf)
            for _ in range(args.runs):
                copies = [_copy(a, wrote) for a, _, wrote, _ in calls]
                for i, (c, (_, k, _, _)) in enumerate(zip(copies, calls)):
                    cpu, wall = time.process_time(), time.perf_counter()
                    kernel(*c, **k)
                    wall = time.perf_counter() - wall
                    best[i] = min(best[i], wall, time.process_time() - cpu)
            total = np.inf
            for _ in range(max(3, args.runs // 4)):
                copies = [_copy(a, wrote) for a, _, wrote, _ in calls]
                t = time.process_time()
                for c, (_, k, _, _) in zip(copies, calls):
                    kernel(*c, **k)
                total = min(total, time.process_time() - t)
            gc.enable()
            r = res[f"{key}_{mode}"] = {"calls": len(calls), "per_call": float(best.sum()), "total": total,
                                        "same": bool(same)}
            if not args.json:
                print(f"{key:12s} {mode:5s} calls {len(calls):5d}  per-call {r['per_call'] * 1e3:8.2f} ms  "
                      f"total {total * 1e3:8.2f} ms  same {same}", flush=True)
    if args.json:
        print(json.dumps(res))
    return res


def _child(argv: list, src: Path, cache: str | None) -> str:
    env = dict(os.environ, PYTHONPATH=str(src.resolve()) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    if cache:
        env["NUMBA_CACHE_DIR"] = cache
    done = subprocess.run([sys.executable, __file__, *argv], env=env, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"kernel_replay: {' '.join(argv[:2])} under {src} failed:\n{done.stderr[-3000:]}")
    return done.stdout


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    ap.add_argument("what", choices=["capture", "replay"])
    ap.add_argument("kernel", help="a name of ENTRIES (" + ", ".join(ENTRIES) + ") or module:function")
    ap.add_argument("--src", type=Path, action="append", default=[],
                    help="a source tree (capture: one; replay: one or more, old first)")
    ap.add_argument("--models", default="featuretype,t20,screw,U_Joint")
    ap.add_argument("--modes", default="tol", help="tol, paper or tol,paper")
    ap.add_argument("--measure", action="store_true", help="capture with the measurement on")
    ap.add_argument("--use", help="replay: call this module:function with the captured arguments instead "
                    "(e.g. a reference implementation)")
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--rounds", type=int, default=2, help="with --src: each tree's replays, interleaved")
    ap.add_argument("--dir", default="/tmp/kernel_replay")
    ap.add_argument("--keep-cache", action="store_true", help="with --src: the environment's NUMBA_CACHE_DIR")
    ap.add_argument("--json", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if not args.src:
        (capture if args.what == "capture" else replay)(args)
        return
    argv = [args.what, args.kernel, "--models", args.models, "--modes", args.modes, "--runs", str(args.runs),
            "--dir", args.dir] + (["--measure"] if args.measure else []) + (["--use", args.use] if args.use else [])
    if args.what == "capture":
        print(_child(argv, args.src[0], None), end="")
        return
    with tempfile.TemporaryDirectory(prefix="kernel_replay_numba_") as tmp:
        caches = [None if args.keep_cache else f"{tmp}/{i}" for i in range(len(args.src))]
        runs = [[] for _ in args.src]
        for r in range(args.rounds):
            for i, src in enumerate(args.src):
                runs[i].append(json.loads(_child(argv + ["--json"], src, caches[i]).splitlines()[-1]))
                print(f"round {r + 1} tree {i} ({src}) done", file=sys.stderr, flush=True)
    best = [{m: {c: min(x[m][c] for x in tree) for c in ("per_call", "total")} for m in tree[0]} for tree in runs]
    print(f"{args.kernel}: ms, best of {args.rounds} rounds x {args.runs} runs; trees "
          + ", ".join(map(str, args.src)) + "; ratio = last / first")
    ratios = {"per_call": [], "total": []}
    for m, first in runs[0][0].items():
        row = f"{m:18s} calls {first['calls']:5d}"
        if not first["calls"]:
            print(row + "  (no call)")
            continue
        for c, v in ratios.items():
            v.append(best[-1][m][c] / best[0][m][c])
            row += f"  {c} " + " ".join(f"{b[m][c] * 1e3:8.2f}" for b in best) + f"  ratio {v[-1]:.3f}"
        print(row + "  same " + "/".join(str(all(x[m]["same"] for x in tree)) for tree in runs))
    if ratios["total"]:
        print("geometric mean of the ratios: " + "  ".join(
            f"{c} {float(np.exp(np.mean(np.log(v)))):.3f}" for c, v in ratios.items()))


if __name__ == "__main__":
    main()

"""reduce_seams and clean_pslg alone (issue 17, item 1; session 29): capture their calls during one tessellate_shell
per model, then replay them (best of N, process CPU) and check the outputs bit for bit against the capture.

    PYTHONPATH=OLD/src python benchmarks/seams_replay.py capture --models t20,U_Joint,turbine [--mode paper]
    PYTHONPATH=src python benchmarks/seams_replay.py replay --models ... --runs 20
    PYTHONPATH=OLD/src python benchmarks/seams_replay.py replay ...          (the before column)

`reduce_seams` is the shell's seam reduction (`tessellate.seams`); `clean_pslg` runs only for the faces whose
constraint graph `_domain_prepare_kernel` cannot hand to Triangle at once (`triangulate_domain`'s numpy path):
no call on most models.
"""

from __future__ import annotations

import argparse
import hashlib
import pickle
import time
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "cad"
if not DATA.exists():
    DATA = Path("/work/shared/data/cad")


def _digest(res) -> str:
    h = hashlib.sha1()
    for x in res:
        if hasattr(x, "vertices"):
            for a in (x.vertices, x.triangles, x.face_id):
                h.update(np.ascontiguousarray(a).tobytes())
        else:
            h.update(np.ascontiguousarray(np.asarray(x)).tobytes())
    return h.hexdigest()


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("what", choices=["capture", "replay"])
    ap.add_argument("--models", default="featuretype,t20,screw,U_Joint")
    ap.add_argument("--mode", choices=["tol", "paper"], default="tol")
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--dir", default="/tmp/seams_replay")
    args = ap.parse_args(argv)
    from trimsurf.tessellate import grid, pslg, seams

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
            calls = {"reduce_seams": [], "clean_pslg": []}
            o_seams, o_clean = seams.reduce_seams, grid.clean_pslg

            def cap_seams(*a, **k):
                res = o_seams(*a, **k)
                calls["reduce_seams"].append((a, k, _digest(res)))
                return res

            def cap_clean(q, seg, *, eps):
                res = o_clean(q, seg, eps=eps)
                calls["clean_pslg"].append(((np.array(q), np.array(seg)), {"eps": eps}, _digest(res)))
                return res

            seams.reduce_seams, grid.clean_pslg = cap_seams, cap_clean
            try:
                tessellate_shell(shell, tolerance=1e-3 * d, max_edge=d if args.mode == "tol" else 3e-2 * d,
                                 measure=False)
            finally:
                seams.reduce_seams, grid.clean_pslg = o_seams, o_clean
            path.write_bytes(pickle.dumps(calls))
            print(f"{key}: " + ", ".join(f"{len(v)} {n}" for n, v in calls.items()) + f" -> {path}")
            continue
        calls = pickle.loads(path.read_bytes())
        for fname, fn in (("reduce_seams", seams.reduce_seams), ("clean_pslg", pslg.clean_pslg)):
            cs = calls[fname]
            if not cs:
                continue
            same = all(_digest(fn(*a, **k)) == ref for a, k, ref in cs)
            best = np.inf
            for _ in range(args.runs):
                t = time.process_time()
                for a, k, _ in cs:
                    fn(*a, **k)
                best = min(best, time.process_time() - t)
            print(f"{key:12s} {args.mode:5s} {fname:12s} calls {len(cs):3d}  best {best * 1e3:7.2f} ms  "
                  f"identical {same}")


if __name__ == "__main__":
    main()

"""Per-face CPU of `mesh_face_from_chunks` (issue 17, the mesh_faces stage) by replaying its calls.

One tessellation (`measure=False`) records every call's arguments; each call is then replayed `--runs`
times and the best time (perf_counter) of each summed: less noisy on a shared machine than the stage
column of tessellate_stages.py (the same work, warm caches). Compare two trees by running this file with
each on PYTHONPATH:

    PYTHONPATH=src python benchmarks/mesh_faces_replay.py --models featuretype,U_Joint [--mode paper]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "cad"
if not DATA.exists():
    DATA = Path("/work/shared/data/cad")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--models", default="featuretype,t20,screw,U_Joint")
    ap.add_argument("--mode", choices=["tol", "paper"], default="tol")
    ap.add_argument("--runs", type=int, default=9)
    args = ap.parse_args(argv)
    import trimsurf.tessellate.shell as shell_mod
    from trimsurf.io import read_shell
    from trimsurf.tessellate import tessellate_shell

    real = shell_mod.mesh_face_from_chunks
    calls: list = []

    def rec(*a, **k):
        calls.append((a, k))
        return real(*a, **k)

    files = sorted(p.name for p in DATA.iterdir() if p.suffix.lower() in (".step", ".stp", ".iges", ".igs"))
    for key in args.models.split(","):
        name = next(n for n in files if key in n)
        shell = read_shell(DATA / name)
        d = shell.diagonal()
        h = d if args.mode == "tol" else 3e-2 * d
        tessellate_shell(shell, tolerance=1e-3 * d, max_edge=h, measure=False)        # warm (numba cache)
        calls.clear()
        shell_mod.mesh_face_from_chunks = rec
        try:
            tessellate_shell(shell, tolerance=1e-3 * d, max_edge=h, measure=False)
        finally:
            shell_mod.mesh_face_from_chunks = real
        total = 0.0
        for a, k in calls:
            best = float("inf")
            for _ in range(args.runs):
                t = time.perf_counter()
                real(*a, **k)
                best = min(best, time.perf_counter() - t)
            total += best
        print(f"{name[:28]:28s} {args.mode:5s} faces {len(calls):4d}  mesh_face_from_chunks {1e3 * total:7.2f} ms "
              f"(sum of per-face best of {args.runs})", flush=True)


if __name__ == "__main__":
    main()

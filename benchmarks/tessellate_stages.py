"""CPU time of tessellate_shell's stages (issue 17): meshing only (measure=False), best of N runs.

Each stage function is wrapped by a process-time accumulator (nested stages count inside their callers:
`triangulate_domain` inside `mesh_face_from_chunks`, `clean_pslg` and Triangle inside
`triangulate_domain`, `refine_cells` inside `face_domain_values`). The row is the run with the
smallest total. Compare two versions of the code by running this file with each on PYTHONPATH:

    PYTHONPATH=src python benchmarks/tessellate_stages.py --models featuretype,t20,screw,U_Joint
    PYTHONPATH=/path/to/old/src python benchmarks/tessellate_stages.py --models ...

--mode tol: eps = 1e-3 of the diagonal, max edge = the diagonal (tolerance only); paper: max edge 3%.
"""

from __future__ import annotations

import argparse
import collections
import time
from pathlib import Path

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "cad"
if not DATA.exists():
    DATA = Path("/work/shared/data/cad")

STAGES = [  # (module, attribute, label)
    ("trimsurf.tessellate.shell", "repair_face", "repair"),
    ("trimsurf.tessellate.shell", "quick_repairs", "repair"),      # (the batched repair, where it exists)
    ("trimsurf.tessellate.shell", "face_domain_values", "domain_values"),
    ("trimsurf.tessellate.shell", "shell_domain_values", "domain_values"),    # jobs=1 since session 25
    ("trimsurf.tessellate.face", "refine_cells", "refine_cells"),
    ("trimsurf.tessellate.shell", "_conforming_chunks", "edges"),
    ("trimsurf.tessellate.shell", "mesh_face_from_chunks", "mesh_faces"),
    ("trimsurf.tessellate.face", "triangulate_domain", "triangulate"),
    ("trimsurf.tessellate.grid", "clean_pslg", "clean_pslg"),
    ("triangle", "triangulate", "Triangle"),
    ("trimsurf.tessellate.grid", "_triang", "Triangle"),       # the wrapper's core
    ("trimsurf.tessellate.face", "collapse_boundary_slivers", "slivers"),
    ("trimsurf.tessellate.face", "collapse_face_slivers", "slivers"),   # s27-faces: the faces' call
    ("trimsurf.tessellate.seams", "reduce_seams", "seams"),
    ("trimsurf.tessellate.stitch", "stitch_mesh", "stitch"),
]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--models", default="featuretype,t20,screw,U_Joint")
    ap.add_argument("--mode", choices=["tol", "paper"], default="tol")
    ap.add_argument("--runs", type=int, default=3)
    args = ap.parse_args(argv)
    import importlib

    acc: dict = collections.defaultdict(float)
    for mod_name, attr, label in STAGES:
        mod = importlib.import_module(mod_name)
        if not hasattr(mod, attr):
            continue
        f = getattr(mod, attr)

        def wrapped(*a, _f=f, _label=label, **k):
            t = time.process_time()
            try:
                return _f(*a, **k)
            finally:
                acc[_label] += time.process_time() - t
        setattr(mod, attr, wrapped)
    from trimsurf.io import read_shell
    from trimsurf.tessellate import tessellate_shell

    files = sorted(p.name for p in DATA.iterdir() if p.suffix.lower() in (".step", ".stp", ".iges", ".igs"))
    labels = list(dict.fromkeys(s[2] for s in STAGES))
    print(f"{'model':28s} {'total':>6s} " + " ".join(f"{x:>13s}" for x in labels))
    for key in args.models.split(","):
        name = next(n for n in files if key in n)
        shell = read_shell(DATA / name)
        d = shell.diagonal()
        h = d if args.mode == "tol" else 3e-2 * d
        tessellate_shell(shell, tolerance=1e-3 * d, max_edge=h, measure=False)     # warm (numba cache)
        best = None
        for _ in range(args.runs):
            acc.clear()
            t = time.process_time()
            tessellate_shell(shell, tolerance=1e-3 * d, max_edge=h, measure=False)
            t = time.process_time() - t
            if best is None or t < best[0]:
                best = (t, dict(acc))
        print(f"{name[:28]:28s} {best[0]:6.3f} " + " ".join(f"{best[1].get(x, 0.0):13.3f}" for x in labels),
              flush=True)


if __name__ == "__main__":
    main()

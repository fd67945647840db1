"""CPU time of tessellate_shell's shell-level stages and of what no stage holds (issue 17), best of N runs.

The columns: the per-face stages as `tessellate_stages.py` has them (repair, domain_values, edges,
mesh_faces with its parts triangulate, tri_dev (the per-triangle deviation bound of the face meshes,
`face.triangle_deviation`) and slivers; loose_chunks in loose mode), then the shell-level ones:
assemble (`_assemble_conforming`), seams (`reduce_seams`), stitch (`stitch_mesh`), merge (loose mode:
`merge_face_meshes`, holding its own stitch and seams), orient, to_trimesh (the face meshes handed back)
and rest: the total minus every outermost stage (FaceStatus and report building, parallel_map, mode
detection). A nested stage counts in its caller too; `shell` sums the shell-level columns (outermost
only) and rest; the row is the run with the smallest `shell`. Compare two versions by running this
file with each on PYTHONPATH:

    PYTHONPATH=src python benchmarks/tessellate_shell_stages.py --models featuretype,t20,screw,U_Joint,bearing
    PYTHONPATH=src python benchmarks/tessellate_shell_stages.py --mode paper

--mode tol: eps = 1e-3 of the diagonal, max edge = the diagonal (tolerance only); paper: max edge 3%.
"""

from __future__ import annotations

import argparse
import collections
import importlib
import time
from pathlib import Path

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "cad"
if not DATA.exists():
    DATA = Path("/work/shared/data/cad")

STAGES = [  # (module, attribute, label, shell-level)
    ("trimsurf.tessellate.shell", "repair_face", "repair", False),
    ("trimsurf.tessellate.shell", "quick_repairs", "repair", False),     # (the batched repair, where it exists)
    ("trimsurf.tessellate.shell", "face_domain_values", "domain_values", False),
    ("trimsurf.tessellate.shell", "shell_domain_values", "domain_values", False),     # jobs=1 since session 25
    ("trimsurf.tessellate.shell", "_conforming_chunks", "edges", False),
    ("trimsurf.tessellate.shell", "loose_chunks", "loose_chunks", False),
    ("trimsurf.tessellate.shell", "mesh_face_from_chunks", "mesh_faces", False),
    ("trimsurf.tessellate.face", "triangulate_domain", "triangulate", False),
    ("trimsurf.tessellate.face", "triangle_deviation", "tri_dev", False),
    ("trimsurf.tessellate.face", "collapse_boundary_slivers", "slivers", False),
    ("trimsurf.tessellate.shell", "_assemble_conforming", "assemble", True),
    ("trimsurf.tessellate.seams", "reduce_seams", "seams", True),
    ("trimsurf.tessellate.stitch", "stitch_mesh", "stitch", True),
    ("trimsurf.tessellate.stitch", "merge_face_meshes", "merge", True),
    ("trimsurf.tessellate.orient", "orient_meshes", "orient", True),
    ("trimsurf.tessellate.face:FaceMesh", "to_trimesh", "to_trimesh", True),
]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--models", default="featuretype,t20,screw,U_Joint,bearing")
    ap.add_argument("--mode", choices=["tol", "paper"], default="tol")
    ap.add_argument("--runs", type=int, default=5)
    args = ap.parse_args(argv)

    acc: dict = collections.defaultdict(float)
    depth = [0]
    shell_level = {label for *_, label, sl in STAGES if sl}
    for mod_name, attr, label, _ in STAGES:
        mod_name, _, cls = mod_name.partition(":")
        owner = importlib.import_module(mod_name)
        owner = getattr(owner, cls) if cls else owner
        if not hasattr(owner, attr):
            continue
        f = getattr(owner, attr)

        def wrapped(*a, _f=f, _label=label, **k):
            outer = depth[0] == 0
            depth[0] += 1
            t = time.process_time()
            try:
                return _f(*a, **k)
            finally:
                dt = time.process_time() - t
                depth[0] -= 1
                acc[_label] += dt
                if outer:
                    acc["_outer"] += dt
                    if _label in shell_level:
                        acc["_shell"] += dt
        setattr(owner, attr, wrapped)
    from trimsurf.io import read_shell
    from trimsurf.tessellate import tessellate_shell

    files = sorted(p.name for p in DATA.iterdir() if p.suffix.lower() in (".step", ".stp", ".iges", ".igs"))
    labels = list(dict.fromkeys(s[2] for s in STAGES)) + ["rest", "shell"]
    print(f"{'model':14s} {'tris':>6s} {'total':>6s} " + " ".join(f"{x[:11]:>11s}" for x in labels))
    for key in args.models.split(","):
        name = next(n for n in files if key in n)
        shell = read_shell(DATA / name)
        d = shell.diagonal()
        h = d if args.mode == "tol" else 3e-2 * d
        res = tessellate_shell(shell, tolerance=1e-3 * d, max_edge=h, measure=False)     # warm (numba cache)
        best = None
        for _ in range(args.runs):
            acc.clear()
            t = time.process_time()
            tessellate_shell(shell, tolerance=1e-3 * d, max_edge=h, measure=False)
            t = time.process_time() - t
            row = dict(acc)
            row["rest"] = t - row.get("_outer", 0.0)
            row["shell"] = row.get("_shell", 0.0) + row["rest"]
            if best is None or row["shell"] < best[1]["shell"]:
                best = (t, row)
        print(f"{key[:14]:14s} {res.mesh.n_triangles:6d} {best[0]:6.3f} "
              + " ".join(f"{best[1].get(x, 0.0):11.4f}" for x in labels), flush=True)


if __name__ == "__main__":
    main()

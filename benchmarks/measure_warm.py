"""How often does the report's warm-started first pass end at another foot than the full search? (issue 17, item 2)

`quality.deviation._first_pass` projects a face's vertices with the full search (nearest seed, crease
restarts, far-seed retries) and every other first-pass sample (edge nodes, centroids: density 3) with one
Newton run from the same barycentric combination of its corners' feet (`_project_warm`), falling back to
the full search where that run does not converge, ends on a domain edge or beyond its triangle's bound.
On each pickled mesh of ``measure_same.py meshes DIR``, per face, every sample is also projected with the
full search (main's first pass) and the two distances compared:

- ``same``: within 1e-9 relative or the projection tolerance (tol_rel x the face's control-net diagonal:
  samples on the surface itself have distances of rounding size) (the same foot);
- ``warm>``: the warm run ended farther (another local minimum: the value reported is above the true
  distance, conservative for mesh -> surface);
- ``warm<``: the full search ended farther (its seed run and restarts missed the foot the warm run found);
- ``fallback``: rows the warm path searched in full anyway (same numbers as the full search);
- ``max rel``: the largest relative difference among ``same`` with distances above 1000 tol; ``worst>`` / ``worst<`` the largest
  difference of the other two kinds relative to the face's largest first-pass value.

Usage: PYTHONPATH=src python benchmarks/measure_warm.py DIR [--models a,b] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import pickle
import sys
from pathlib import Path

import numpy as np


def _face_rows(mesh, shell, tol_rel=1e-10):
    import trimsurf.quality.deviation as D
    from trimsurf.quality.sampling import as_face, sample_triangles

    order = np.argsort(mesh.face_id, kind="stable")
    bounds = np.searchsorted(mesh.face_id[order], np.arange(len(shell.faces) + 1))
    out = []
    for i in range(len(shell.faces)):
        if bounds[i + 1] == bounds[i]:
            continue
        sub = mesh.submesh(np.sort(order[bounds[i]:bounds[i + 1]]))
        face = as_face(shell.faces[i])
        samples = sample_triangles(sub, density=3)
        rows = np.arange(len(samples.points))
        fallback = [0]
        full_fn = D.project_to_face

        def counting(points, f, **k):
            if k.get("uv0") is None:
                fallback[0] += len(points)
            return full_fn(points, f, **k)
        D.project_to_face = counting
        try:
            warm, _, _ = D._first_pass(sub, face, samples, rows, tol_rel)
        finally:
            D.project_to_face = full_fn
        n_vert = int(np.count_nonzero(samples.kind == 0))
        full = D.project_to_face(samples.points, face, tol_rel=tol_rel).distance
        other = samples.kind != 0
        cp = np.asarray(face.surface.control_points).reshape(-1, 3)
        tol = tol_rel * float(np.linalg.norm(cp.max(axis=0) - cp.min(axis=0)))
        out.append((warm[other], full[other], max(float(np.max(full)), 1e-300), fallback[0] - n_vert, tol))
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("folder")
    p.add_argument("--models", help="comma-separated substrings of the pickles' names")
    p.add_argument("--json")
    a = p.parse_args(argv)
    import trimsurf.geom.projection as projection

    files = sorted(Path(a.folder).glob("*.pkl"))
    if a.models:
        keys = a.models.split(",")
        files = [f for f in files if any(k in f.stem for k in keys)]
    print(f"{'mesh':48} {'nodes':>7} {'same':>7} {'warm>':>5} {'warm<':>5} {'fallbk':>6} {'max rel':>8} "
          f"{'worst>':>8} {'worst<':>8}")
    rows = []
    for f in files:
        shell, r = pickle.loads(f.read_bytes())
        projection._SEED_CACHE.clear()
        n = same = up = down = fb = 0
        max_rel = worst_up = worst_down = 0.0
        for warm, full, face_max, fallback, tol in _face_rows(r.mesh, shell):
            rel = np.abs(warm - full) / np.maximum(np.abs(full), 1e-300)
            eq = (np.abs(warm - full) <= 1e-9 * np.abs(full) + tol) | (warm == full)
            n += len(warm)
            same += int(eq.sum())
            hi, lo = ~eq & (warm > full), ~eq & (warm < full)
            up += int(hi.sum())
            down += int(lo.sum())
            fb += fallback
            big = eq & (np.abs(full) > 1e3 * tol)
            if big.any():
                max_rel = max(max_rel, float(np.max(rel[big])))
            if hi.any():
                worst_up = max(worst_up, float(np.max(warm[hi] - full[hi])) / face_max)
            if lo.any():
                worst_down = max(worst_down, float(np.max(full[lo] - warm[lo])) / face_max)
        rows.append(dict(mesh=f.stem, nodes=n, same=same, warm_larger=up, warm_smaller=down, fallback=fb,
                         max_rel_same=max_rel, worst_larger=worst_up, worst_smaller=worst_down))
        print(f"{f.stem:48} {n:7d} {same:7d} {up:5d} {down:5d} {fb:6d} {max_rel:8.1e} {worst_up:8.1e} "
              f"{worst_down:8.1e}", flush=True)
    if a.json:
        Path(a.json).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())

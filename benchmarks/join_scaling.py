"""Joining two mesh patches: time against n (vertices) x sigma (boundary segments per patch).

The paper (join-mesh-patches-whitney.txt, Sec. IV-B) joined 2.1K nodes with sigma = 80 boundary segments
in 8.16 s on a 2.2 GHz Athlon 64, cost proportional to n x sigma (65-85 % of it in the Whitney
reprojection). Here: the two curved faces of `trimsurf.samples.folding_pair` (bicubic, sharing an edge
with its own 3D curve b(t)), each meshed by a regular k x k grid in (u, v) (vertices up to 1e-4 off the
surface, their grid uv given as a warm start), joined by `trimsurf.join.join_shell` (Case 1) with the edge curves sampled so that each patch
boundary has about sigma segments. Columns:

* ``join_s``: the whole join (projection, central mesh, Triangle, size refinement, Whitney, merge), best
  of REPEATS, at the join's default deflection: the input grids' own deviation inside the triangles
  (measured before the timing, `grid_deviation`), so the strip Triangle adds is refined to it;
* ``project_s``, ``whitney_s``: the projection of the meshes and the (pruned, exact) Whitney step;
* ``paper_s``: the paper's constant applied to this n x sigma (8.16 s x n sigma / (2.1K x 80));
* ``paper/ours``: how many times faster than the paper's proportional cost;
* ``allpairs_s``: the Whitney step of face 0 evaluated at every (query, segment) pair (the paper's
  n x sigma method): `trimsurf.geom.whitney.whitney_average` with one block holding every segment,
  so nothing is pruned (the same compiled closed form), on the same data, for n <= 300K (run in the
  same process; "-" where it would take long); ``allpairs/pruned`` the speed-up of the pruning on
  that face. Both give the same values (max difference printed as ``max|diff|``).

Side by side (``--reference SRC``): the same sizes joined alternately by this checkout's trimsurf and by
the one whose ``src`` folder is SRC (e.g. ``git archive 671caca src | tar -x -C /tmp/ref`` then
``--reference /tmp/ref/src``), each in a fresh child process, ``--rounds`` times; printed per size: the
best-of-``--repeats`` join time of every round and their medians, so both see the same machine load. A
reference without the ``deflection`` argument (before issue 13) joins without the size refinement.

Usage: python benchmarks/join_scaling.py [--json out.json] [--quick | --sizes N:SIGMA,...]
       [--reference SRC [--rounds K] [--repeats R]]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from trimsurf.geom.whitney import whitney_average
from trimsurf.join import join_shell
from trimsurf.model import TriMesh
from trimsurf.samples.folding_pair import folding_pair

PAPER_SECONDS, PAPER_N, PAPER_SIGMA = 8.16, 2100, 80
SIZES = [(2100, 80), (10_000, 160), (100_000, 320), (300_000, 500), (1_000_000, 1000)]
QUICK = [(2100, 80), (10_000, 160)]
ALLPAIRS_MAX_N = 300_000
REPEATS = 3


def grid_meshes(shell, n_total: int) -> list[TriMesh]:
    """Each face: a k x k grid in (u, v) with 2 (k-1)^2 triangles; 2 k^2 ~ n_total vertices.

    The vertices sit a little off the surface (heights eta up to 1e-4 of the 2 x 1 pair along the normal,
    varying over the patch), so step 1 really projects them, as it would a tessellator's or a scanner's mesh.
    """
    k = max(3, int(round(np.sqrt(n_total / 2))))
    g = np.linspace(0.0, 1.0, k)
    uu, vv = np.meshgrid(g, g, indexing="ij")
    uv = np.column_stack([uu.ravel(), vv.ravel()])
    i, j = np.meshgrid(np.arange(k - 1), np.arange(k - 1), indexing="ij")
    a = (i * k + j).ravel()
    tris = np.concatenate([np.column_stack([a, a + k, a + k + 1]), np.column_stack([a, a + k + 1, a + 1])])
    eta = 1e-4 * np.sin(7.0 * uv[:, 0]) * np.cos(5.0 * uv[:, 1])
    out = []
    for face in shell.faces:
        pts = face.surface.evaluate(uv) + eta[:, None] * face.surface.normals(uv)
        out.append(TriMesh(pts, tris, uv=uv))
    return out


def perimeter(face) -> float:
    total = 0.0
    for loop in face.loops:
        for seg in loop.segments:
            t = seg.parameters(65)
            p = face.surface.evaluate(seg.evaluate(t))
            total += float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum())
    return total


def grid_deviation(shell, meshes, n: int) -> float:
    """The input grids' largest deviation inside the triangles (the join's default deflection), untimed.

    Measured on every triangle up to 100K vertices; above, on 20K random triangles per face (an estimate).
    """
    from trimsurf.join import input_deviation

    if n <= 100_000:
        return input_deviation(shell, meshes)
    rng = np.random.default_rng(0)
    subs = [TriMesh(m.vertices, m.triangles[rng.choice(m.n_triangles, 20_000, replace=False)], uv=m.uv)
            for m in meshes]
    return input_deviation(shell, subs)


def run_size(shell, n: int, sigma: int, repeats: int, allpairs: bool = True) -> dict:
    import inspect

    meshes = grid_meshes(shell, n)
    spacing = max(perimeter(f) for f in shell.faces) / sigma
    sized = "deflection" in inspect.signature(join_shell).parameters   # False: a version before issue 13
    deflection = grid_deviation(shell, meshes, n) if sized else None
    kw = {"deflection": deflection} if sized else {}
    best, res = float("inf"), None
    for _ in range(repeats):
        t = time.perf_counter()
        r = join_shell(shell, meshes, edge_spacing=spacing, measure=False, **kw)
        dt = time.perf_counter() - t
        if dt < best:
            best, res = dt, r
    assert res, "join failed"
    n_act = sum(m.n_vertices for m in meshes)
    sig = res.report["boundary_segments_max"]
    paper = PAPER_SECONDS * n_act * sig / (PAPER_N * PAPER_SIGMA)
    row = {"n": n_act, "sigma": sig, "join_s": best, "project_s": res.report["seconds_project"],
           "whitney_s": res.report["seconds_steps"]["whitney"], "triangulate_s": res.report["seconds_steps"]["triangulate"],
           "paper_s": paper, "paper_over_ours": paper / best, "allpairs_s": None, "allpairs_over_pruned": None,
           "max_abs_diff": None, "output_triangles": res.mesh.n_triangles,
           "watertight_joint": res.report["boundary_edges_on_joins"] == 0, "deflection": deflection,
           "refine_s": res.report["seconds_steps"].get("refine", 0.0)}
    if allpairs and n_act <= ALLPAIRS_MAX_N:
        r0 = res.patches[0]
        bd = r0.boundary
        q = r0.uv * r0.scale
        t = time.perf_counter()
        ref = whitney_average(bd, q, block=len(bd.length))  # one block: every (query, segment) pair
        t_all = time.perf_counter() - t
        t = time.perf_counter()
        got = whitney_average(bd, q)
        t_pr = time.perf_counter() - t
        row.update({"allpairs_s": t_all, "allpairs_over_pruned": t_all / t_pr,
                    "max_abs_diff": float(np.max(np.abs(ref.average - got.average)))})
    return row


def side_by_side(reference: Path, sizes, rounds: int, repeats: int) -> list[dict]:
    """Join every size alternately with the reference's src and this checkout's, `rounds` times (child processes)."""
    import os
    import subprocess

    mine = Path(__file__).resolve().parents[1] / "src"
    runs: dict[str, list[list[dict]]] = {"reference": [], "this": []}
    for k in range(rounds):
        for label, src in (("reference", reference), ("this", mine)):
            env = dict(os.environ, PYTHONPATH=str(src))
            cmd = [sys.executable, __file__, "--child", ",".join(f"{n}:{s}" for n, s in sizes),
                   "--repeats", str(repeats)]
            out = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True).stdout
            runs[label].append(json.loads(out.strip().splitlines()[-1]))
            print(f"round {k + 1} {label:<9} " + "  ".join(f"n={r['n']}: {1e3 * r['join_s']:.1f} ms"
                                                          for r in runs[label][-1]), flush=True)
    rows = []
    print(f"{'n':>9} {'sigma':>6} {'ref_ms (median)':>16} {'this_ms (median)':>17} {'this/ref':>8}")
    for j in range(len(sizes)):
        ref = [r[j]["join_s"] for r in runs["reference"]]
        new = [r[j]["join_s"] for r in runs["this"]]
        row = {"n": runs["this"][0][j]["n"], "sigma": runs["this"][0][j]["sigma"], "reference_s": ref,
               "this_s": new, "reference_median_s": float(np.median(ref)), "this_median_s": float(np.median(new))}
        rows.append(row)
        print(f"{row['n']:>9} {row['sigma']:>6} {1e3 * row['reference_median_s']:>16.1f} "
              f"{1e3 * row['this_median_s']:>17.1f} {row['this_median_s'] / row['reference_median_s']:>8.3f}")
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--json", type=Path, help="also write the rows as JSON")
    parser.add_argument("--quick", action="store_true", help="only the two smallest sizes")
    parser.add_argument("--sizes", help="only these sizes, e.g. 1000000:1000 (n:sigma, comma separated)")
    parser.add_argument("--reference", type=Path, help="src folder of another trimsurf: run side by side")
    parser.add_argument("--rounds", type=int, default=3, help="side by side: alternations (default 3)")
    parser.add_argument("--repeats", type=int, help=f"joins per size, the best kept (default {REPEATS}; "
                                                    f"1 from 300K vertices)")
    parser.add_argument("--child", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    sizes = QUICK if args.quick else SIZES
    if args.sizes:
        sizes = [tuple(int(x) for x in item.split(":")) for item in args.sizes.split(",")]
    if args.reference:
        rows = side_by_side(args.reference.resolve(), sizes, args.rounds, args.repeats or REPEATS)
        if args.json:
            args.json.write_text(json.dumps(rows, indent=2) + "\n")
        return 0
    shell = folding_pair()
    if args.child:   # one side of --reference: rows as one JSON line, no Whitney-only comparison
        join_shell(shell, grid_meshes(shell, 2100))
        out = []
        for item in args.child.split(","):
            n, sigma = (int(x) for x in item.split(":"))
            r = run_size(shell, n, sigma, (args.repeats or REPEATS) if n <= 100_000 else 1, allpairs=False)
            out.append({k: r[k] for k in ("n", "sigma", "join_s", "output_triangles")})
        print(json.dumps(out))
        return 0
    join_shell(shell, grid_meshes(shell, 2100))  # compile the numba kernels outside the timing
    rows = []
    print(f"{'n':>9} {'sigma':>6} {'join_s':>8} {'proj_s':>8} {'whit_s':>8} {'refi_s':>8} {'paper_s':>10} {'paper/ours':>10} "
          f"{'allpairs_s':>10} {'allp/prun':>9} {'max|diff|':>9}", flush=True)
    for n, sigma in sizes:
        r = run_size(shell, n, sigma, (args.repeats or REPEATS) if n <= 100_000 else 1)
        rows.append(r)
        ap = "-" if r["allpairs_s"] is None else f"{r['allpairs_s']:.3f}"
        apr = "-" if r["allpairs_over_pruned"] is None else f"{r['allpairs_over_pruned']:.1f}"
        md = "-" if r["max_abs_diff"] is None else f"{r['max_abs_diff']:.1e}"
        print(f"{r['n']:>9} {r['sigma']:>6} {r['join_s']:>8.3f} {r['project_s']:>8.3f} {r['whitney_s']:>8.3f} "
              f"{r['refine_s']:>8.3f} "
              f"{r['paper_s']:>10.1f} {r['paper_over_ours']:>10.0f} {ap:>10} {apr:>9} {md:>9}", flush=True)
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())

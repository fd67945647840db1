"""Where trimsurf's tolerance-only triangles go against Open CASCADE's, face by face and edge by edge.

For one model (eps = 1e-3 x diagonal, max edge = diagonal, as "tol-only" in tessellate_vs_occt.py):

* per face: our triangles and Open CASCADE's (native shape, ``BRepMesh_IncrementalMesh`` at the linear
  and angular deflection given, e.g. its best matched setting from tessellate_vs_occt.py's table;
  faces matched as that script matches them), the face's degrees, our grid (cells u x v), crossed
  cells and loops; sorted by our excess;
* per shared edge (two uses): its points, how many are crossings of face A's / face B's transverse
  grid lines, how many are neither (3D chord samples between crossings), and how many points the
  chord criterion alone would give the edge (`domain.adaptive_values` at the shared-edge chord
  tolerance, no iso-values inserted); the sums at the end.

Usage: python benchmarks/per_face_occt.py MODEL LINEAR_OVER_EPS ANGULAR [--top 30]
  e.g. ``gmsh__t20_data.step 1.68 0.5``, ``trimesh__featuretype.STEP 2 1.6``, ``occt__screw.step 1.19 0.5``
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import tessellate_vs_occt as B  # noqa: E402

from trimsurf.io import read_shell  # noqa: E402
from trimsurf.tessellate import shell as S  # noqa: E402
from trimsurf.tessellate import trims as T  # noqa: E402
from trimsurf.tessellate.domain import adaptive_values, unique_values  # noqa: E402


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("model")
    parser.add_argument("linear", type=float, help="Open CASCADE's linear deflection / eps")
    parser.add_argument("angular", type=float, help="Open CASCADE's angular deflection (rad)")
    parser.add_argument("--top", type=int, default=30)
    args = parser.parse_args(argv)
    cad = B.DATA / args.model
    shell = read_shell(cad)
    d = shell.diagonal()
    eps = 1e-3 * d
    captured = []
    orig = S.discretize_chunks

    def capture(chunks, **kw):          # the shell's one call with every chunk
        out = orig(chunks, **kw)
        captured.append((chunks, out))
        return out
    S.discretize_chunks = capture
    try:
        res = S.tessellate_shell(shell, tolerance=eps, max_edge=d, measure=False)
    finally:
        S.discretize_chunks = orig
    om, _ = B.occ_mesh(B.native_shape(cad, shell), shell, args.linear * eps, args.angular)
    B.shell_of[0] = shell
    mo, mc = B.measure(res.mesh, shell, d), B.measure(om, shell, d)
    print(f"{args.model}: trimsurf {mo['triangles']} triangles dev/eps {mo['max_dev'] / eps:.3f}; Open CASCADE "
          f"{mc['triangles']} dev/eps {mc['max_dev'] / eps:.3f} (linear {args.linear} eps, angular {args.angular})")
    nf = len(shell.faces)
    ours = np.bincount(res.mesh.face_id, minlength=nf)
    occ = np.bincount(om.face_id, minlength=nf)
    order = np.argsort(occ - ours, kind="stable")
    print(f"{'face':>4s} {'ours':>5s} {'OCCT':>5s} {'excess':>6s} {'degrees':>7s} {'grid':>9s} {'crossed':>7s} "
          f"{'loops':>5s}")
    for i in order[:args.top].tolist():
        f, st = shell.faces[i], res.faces[i]
        print(f"{i:4d} {ours[i]:5d} {occ[i]:5d} {ours[i] - occ[i]:6d} {f.surface.degree_u:3d},{f.surface.degree_v:<3d} "
              f"{st.grid[0]:4d}x{st.grid[1]:<4d} {st.crossed_cells:7d} {len(f.loops):5d}")
    print(f"excess over faces with more triangles than Open CASCADE: {int(np.maximum(ours - occ, 0).sum())}; "
          f"fewer: {int(np.minimum(ours - occ, 0).sum())}")
    chunks, out = captured[0]
    rows = []
    for uses, ch in zip(chunks, out):
        if ch.degenerate or len(uses) < 2:
            continue
        cross = []
        for use, uv in zip(ch.uses, ch.uv):
            on = np.zeros(len(uv), dtype=bool)
            for axis, grid in ((0, use.us), (1, use.vs)):
                c = uv[:, axis]
                if np.ptp(c) > 1e-9 * (grid[-1] - grid[0]):     # transverse lines only (not one it runs along)
                    on |= np.isin(c, grid)
            cross.append(on)
        lo, hi = sorted((uses[0].pcurve.t0, uses[0].pcurve.t1))
        kn = uses[0].pcurve.curve.knots
        init = unique_values(np.concatenate((T._S9, (unique_values(kn[(kn > lo) & (kn < hi)]) - lo) / (hi - lo))))
        chord = adaptive_values(T._evaluator(uses), 0.0, 1.0, tolerance=T.SHARED_CHORD * eps, max_edge=d, init=init)
        rows.append((uses[0].face, uses[1].face, len(ch.s), int(cross[0].sum()), int(cross[1].sum()),
                     int((~cross[0] & ~cross[1]).sum()), len(chord)))
    rows.sort(key=lambda r: r[6] - r[2])
    print(f"shared edges (SHARED_CHORD = {T.SHARED_CHORD}): {'A':>4s} {'B':>4s} {'points':>6s} {'crossA':>6s} "
          f"{'crossB':>6s} {'neither':>7s} {'chord only':>10s}")
    for r in rows[:args.top]:
        print(" " * 36 + f"{r[0]:4d} {r[1]:4d} {r[2]:6d} {r[3]:6d} {r[4]:6d} {r[5]:7d} {r[6]:10d}")
    seg = sum(r[2] - 1 for r in rows)
    seg_chord = sum(r[6] - 1 for r in rows)
    print(f"shared-edge segments: {seg} (chord criterion alone: {seg_chord}); points neither face's crossing: "
          f"{sum(r[5] for r in rows)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

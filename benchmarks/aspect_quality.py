"""The grid cells' aspect limit (`face.ASPECT`, `tessellate_shell(aspect=...)`) against Open CASCADE's own
triangle quality at the same measured deviation (issue 17, item 3).

For every real file of ../shared/data/cad (and the samples with --samples):

* Open CASCADE: its fewest-triangle mesh within eps = 1e-3 x diagonal, searched over linear x angular
  deflection exactly as `tessellate_vs_occt.py` does (`occt_search`; or its settings read back from an
  earlier --json of this script with --occt-from, which re-meshes at them);
* trimsurf tolerance-only (max_edge = diagonal) and at the defaults (max_edge = 3e-2 x diagonal), for each
  aspect setting in --aspects (``none`` = no limit; ``dev`` = no limit on developable faces only: faces
  whose surface is straight along one parameter direction with the same unit normal at both ends of
  every such line, sampled; elsewhere 6);

each mesh measured by the same metric as tessellate_vs_occt.py (two-sided deviation, density 3, 32 x 32
face samples; angles from `triangle_quality`) plus the SHADING error: per triangle, the unit normal
interpolated from the exact normals at its three corners (each corner projected onto the triangle's
face), as Gouraud / Phong / environment mapping shade it, against the exact normal at the foot of the
sample point, at the 15 points of a barycentric grid of 4 divisions per edge (degrees; the max, and the
area-weighted mean and 90th / 99th percentiles; the max is an outlier's, e.g. a foot at a singular point). This is what a reflection line sees of a triangle's shape: thin triangles
along a direction in which the normal does not turn (a cylinder's line) shade as exactly as square ones.

Usage: python benchmarks/aspect_quality.py [--json out.json] [--models a,b] [--aspects 6,12,none,dev]
       [--occt-from earlier.json] [--samples]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import tessellate_vs_occt as tvo  # noqa: E402

from trimsurf.io import read_shell  # noqa: E402
from trimsurf.quality.deviation import project_to_face  # noqa: E402
from trimsurf.samples import build_sample  # noqa: E402
from trimsurf.tessellate import face as face_mod  # noqa: E402
from trimsurf.tessellate import tessellate_shell  # noqa: E402

# barycentric grid, 4 divisions per edge: 15 points (corners, edge points, interior)
_B = np.array([(i / 4, j / 4, (4 - i - j) / 4) for i in range(5) for j in range(5 - i)])


def _weighted_percentile(a, w, q) -> float:
    o = np.argsort(a)
    c = np.cumsum(w[o])
    return float(a[o][min(np.searchsorted(c, q / 100.0 * c[-1]), len(a) - 1)]) if len(a) else 0.0


def shading_error(mesh, shell) -> dict:
    """Angles (deg) between the interpolated corner normals and the exact normal, per sample (see the module);
    percentiles weighted by area (each sample stands for 1/15 of its triangle: fewer triangles on a cylinder,
    whose samples have no error, must not raise the percentile of the rest)."""
    out, wts = [], []
    for f in np.unique(mesh.face_id):
        tri = mesh.triangles[mesh.face_id == f]
        face = shell.faces[int(f)]
        corners = mesh.vertices[tri]                                 # (k, 3, 3)
        area = 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1)
        pc = project_to_face(corners.reshape(-1, 3), face)
        nc = face.oriented_normals(pc.uv).reshape(-1, 3, 3)
        x = np.einsum("bk,tkd->tbd", _B, corners).reshape(-1, 3)
        ps = project_to_face(x, face)
        ns = face.oriented_normals(ps.uv).reshape(len(tri), len(_B), 3)
        m = np.einsum("bk,tkd->tbd", _B, nc)
        with np.errstate(invalid="ignore", divide="ignore"):
            m = m / np.linalg.norm(m, axis=2)[..., None]
            cos = np.einsum("tbd,tbd->tb", m, ns)
        ok = np.isfinite(cos)
        out.append(np.degrees(np.arccos(np.clip(cos[ok], -1.0, 1.0))))
        wts.append(np.broadcast_to(area[:, None], cos.shape)[ok])
    a = np.concatenate(out) if out else np.zeros(0)
    w = np.concatenate(wts) if wts else np.zeros(0)
    return {"shade_max": float(a.max(initial=0.0)), "shade_p99": _weighted_percentile(a, w, 99.0),
            "shade_p90": _weighted_percentile(a, w, 90.0),
            "shade_mean": float((a * w).sum() / w.sum()) if w.sum() > 0 else 0.0}


def developable(surface, n: int = 9, tol: float = 1e-6) -> tuple[bool, bool]:
    """Per parameter direction: its lines are straight (degree 1, one span) and the unit normal is the same
    (within tol rad) at both ends of each of n lines (sampled: a cylinder's, a cone's, an extrusion's lines)."""
    out = []
    (u0, u1), (v0, v1) = surface.domain
    for axis in (0, 1):
        if not face_mod._straight_dir(surface, axis):
            out.append(False)
            continue
        t = np.linspace(0.0, 1.0, n)
        if axis == 0:        # lines along u: v fixed
            a = np.column_stack([np.full(n, u0), v0 + t * (v1 - v0)])
            b = np.column_stack([np.full(n, u1), v0 + t * (v1 - v0)])
        else:
            a = np.column_stack([u0 + t * (u1 - u0), np.full(n, v0)])
            b = np.column_stack([u0 + t * (u1 - u0), np.full(n, v1)])
        na, nb = surface.normals(a), surface.normals(b)
        ok = np.isfinite(na).all() and np.isfinite(nb).all() and bool(
            (np.einsum("ij,ij->i", na, nb) >= math.cos(tol)).all())
        out.append(ok)
    return out[0], out[1]


_EXEMPT = [(False, False)]     # the face being refined: its developable directions ("rul")


def _round_rul(op, dev, diag, diag_max, side_u, side_v, near, interior, has_polys, tolerance, max_edge, aspect,
               min_across, local_fix, long, *rest):
    """refine_round_kernel with op 0's aspect decisions dropped for cells long along a developable direction."""
    out = _ROUND(op, dev, diag, diag_max, side_u, side_v, near, interior, has_polys, tolerance, max_edge, aspect,
                 min_across, local_fix, long, *rest)
    ex_u, ex_v = _EXEMPT[0]
    if op != 0 or not (ex_u or ex_v):
        return out
    by_aspect = long & ~(diag > max_edge) & ~(dev > tolerance)
    long_u = side_u >= side_v       # the cell's long side runs along u
    drop = by_aspect & ((long_u & ex_u) | (~long_u & ex_v))
    long[drop] = False
    go = bool(len(out[1]) > 0 or long.any())
    return go, out[1], out[2]


_ROUND = face_mod.refine_round_kernel


def ours(shell, eps, h, aspect):
    """trimsurf's mesh at `aspect` (a number, None, "dev": None on developable faces, else 6, or "rul": 6
    except for cells long along a developable direction; "rul" runs refine_cells' Python reference)."""
    if aspect == "rul":
        orig_rc, orig_fv = face_mod.refine_cells, face_mod._face_values

        def rc(face, us, vs, **kw):
            return face_mod._refine_cells_rounds(face, us, vs, **kw)

        def fv(face, **kw):
            _EXEMPT[0] = developable(face.surface)
            return orig_fv(face, **kw)
        face_mod.refine_cells, face_mod._face_values, face_mod.refine_round_kernel = rc, fv, _round_rul
        try:
            return tessellate_shell(shell, tolerance=eps, max_edge=h, measure=False).mesh
        finally:
            face_mod.refine_cells, face_mod._face_values, face_mod.refine_round_kernel = orig_rc, orig_fv, _ROUND
    if aspect != "dev":
        return tessellate_shell(shell, tolerance=eps, max_edge=h, measure=False, aspect=aspect).mesh
    orig = face_mod._face_values

    def patched(face, **kw):
        kw["aspect"] = None if any(developable(face.surface)) else face_mod.ASPECT
        return orig(face, **kw)
    face_mod._face_values = patched
    try:
        return tessellate_shell(shell, tolerance=eps, max_edge=h, measure=False, aspect=face_mod.ASPECT).mesh
    finally:
        face_mod._face_values = orig


def measure(mesh, shell, diag):
    return tvo.measure(mesh, shell, diag) | shading_error(mesh, shell)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--json", type=Path)
    ap.add_argument("--models", default="")
    ap.add_argument("--aspects", default="6,12,none,dev,rul")
    ap.add_argument("--occt-from", type=Path, help="Open CASCADE's settings from an earlier --json of this script")
    ap.add_argument("--samples", action="store_true", help="the shell samples too")
    ap.add_argument("--comparable", action="store_true", help="leave out bearing and abc (Open CASCADE beyond eps)")
    args = ap.parse_args(argv)
    aspects = [None if a == "none" else a if a in ("dev", "rul") else float(a) for a in args.aspects.split(",")]
    known = {}
    if args.occt_from:
        known = {r["model"]: r["occt"] for r in json.loads(args.occt_from.read_text())["rows"]}
    models = [(p.name, p) for p in sorted(tvo.DATA.iterdir()) if p.suffix.lower() in (".step", ".stp", ".iges", ".igs")]
    if args.samples:
        models += [(s, s) for s in tvo.SAMPLES]
    if args.comparable:     # the 12 real files both meshers get within eps (tessellate_vs_occt.py's means)
        models = [m for m in models if m[0] not in ("occt__bearing.iges", "occtpr946__bug32596_abc_0_13.step")]
    if args.models:
        keep = set(args.models.split(","))
        models = [m for m in models if m[0] in keep]
    rows = []
    for name, src in models:
        shell = build_sample(src) if isinstance(src, str) else read_shell(src)
        diag = shell.diagonal()
        eps, h = tvo.REL_TOL * diag, tvo.REL_H * diag
        row = {"model": name, "eps": eps}
        shape = tvo.native_shape(None if isinstance(src, str) else src, shell)
        tvo.shell_of[0] = shell
        if name in known:
            lin, ang = known[name]["deflection"], known[name]["angular_deflection"]
            om = tvo.occ_mesh(shape, shell, lin, ang)[0]
        else:
            m, _, lin, ang = tvo.occ_search(shape, shell, eps, diag)
            om = tvo.occ_mesh(shape, shell, lin, ang)[0]
        row["occt"] = measure(om, shell, diag) | {"deflection": lin, "angular_deflection": ang}
        for a in aspects:
            key = "none" if a is None else str(a)
            for mode, hh in (("tol", diag), ("paper", h)):
                row[f"{mode}_{key}"] = measure(ours(shell, eps, hh, a), shell, diag)
        rows.append(row)
        if args.json:       # after every model (a long run's rows so far)
            args.json.write_text(json.dumps({"rows": rows}, indent=1, default=float) + "\n")
        o = row["occt"]
        print(f"{name[:28]:28s} OCCT tri {o['triangles']:6d} dev/eps {o['max_dev'] / eps:5.2f} p5 {o['p5_angle']:5.2f} "
              f"min {o['min_angle']:5.2f} shade mean {o['shade_mean']:5.3f} p90 {o['shade_p90']:5.2f} p99 {o['shade_p99']:5.2f}", flush=True)
        for a in aspects:
            key = "none" if a is None else str(a)
            for mode in ("tol", "paper"):
                r = row[f"{mode}_{key}"]
                print(f"{'':28s} {mode:5s} {key:5s} tri {r['triangles']:6d} dev/eps {r['max_dev'] / eps:5.2f} "
                      f"p5 {r['p5_angle']:5.2f} min {r['min_angle']:5.2f} shade mean {r['shade_mean']:5.3f} "
                      f"p90 {r['shade_p90']:5.2f} p99 {r['shade_p99']:5.2f} bnd {r['boundary']} nm {r['nonmanifold']}", flush=True)
    if args.json:
        args.json.write_text(json.dumps({"rows": rows}, indent=1, default=float) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())

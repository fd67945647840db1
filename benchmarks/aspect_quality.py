"""The grid cells' aspect limit (`face.ASPECT`, `tessellate_shell(aspect=...)`) against Open CASCADE's own
triangle quality at the same measured deviation (issue 17, item 3).

For every real file of ../shared/data/cad (and the samples with --samples):

* Open CASCADE: its fewest-triangle mesh within eps = 1e-3 x diagonal, searched over linear x angular
  deflection exactly as `tessellate_vs_occt.py` does (`occt_search`; or its settings read back from an
  earlier --json of this script with --occt-from, which re-meshes at them);
* trimsurf tolerance-only (max_edge = diagonal) and at the defaults (max_edge = 3e-2 x diagonal), for each
  aspect setting in --aspects: a number = that limit on every face (``face.LIMIT_DEVELOPABLE``, the rule
  before session 29), ``none`` = no limit, ``default`` = trimsurf's default (6, developable faces not
  limited: `face._developable`);

each mesh measured by the same metric as tessellate_vs_occt.py (two-sided deviation, density 3, 32 x 32
face samples; angles from `triangle_quality`) plus the SHADING error: per triangle, the unit normal
interpolated from the exact normals at its three corners (each corner projected onto the triangle's
face), as Gouraud / Phong / environment mapping shade it, against the exact normal at the foot of the
sample point, at the 15 points of a barycentric grid of 4 divisions per edge (degrees; the max, and the
area-weighted mean and 90th / 99th percentiles; the max is an outlier's, e.g. a foot at a singular point). This is what a reflection line sees of a triangle's shape: thin triangles
along a direction in which the normal does not turn (a cylinder's line) shade as exactly as square ones.

Usage: python benchmarks/aspect_quality.py [--json out.json] [--models a,b] [--aspects 6,12,none,default]
       [--occt-from earlier.json] [--samples] [--comparable]

Session 29's run (RESULTS.md "aspect limit") also had two experimental variants, since removed: no limit
on faces whose normal is the same at both ends of 9 sampled straight lines (the same faces as
`face._developable` on all 14 files) and, in refine_cells' Python reference, no limit only for cells
long ALONG such lines (the same meshes as the per-face rule on all 12 comparable files).
"""

from __future__ import annotations

import argparse
import json
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


def ours(shell, eps, h, aspect):
    """trimsurf's mesh: `aspect` a number or None: that limit on EVERY face (`face.LIMIT_DEVELOPABLE`, the
    rule before session 29); "default": tessellate_shell's default (ASPECT, developable faces not limited)."""
    if aspect == "default":
        return tessellate_shell(shell, tolerance=eps, max_edge=h, measure=False).mesh
    old = face_mod.LIMIT_DEVELOPABLE
    face_mod.LIMIT_DEVELOPABLE = True
    try:
        return tessellate_shell(shell, tolerance=eps, max_edge=h, measure=False, aspect=aspect).mesh
    finally:
        face_mod.LIMIT_DEVELOPABLE = old


def measure(mesh, shell, diag):
    return tvo.measure(mesh, shell, diag) | shading_error(mesh, shell)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--json", type=Path)
    ap.add_argument("--models", default="")
    ap.add_argument("--aspects", default="6,12,none,default")
    ap.add_argument("--occt-from", type=Path, help="Open CASCADE's settings from an earlier --json of this script")
    ap.add_argument("--samples", action="store_true", help="the shell samples too")
    ap.add_argument("--comparable", action="store_true", help="leave out bearing and abc (Open CASCADE beyond eps)")
    args = ap.parse_args(argv)
    aspects = [None if a == "none" else a if a == "default" else float(a) for a in args.aspects.split(",")]
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

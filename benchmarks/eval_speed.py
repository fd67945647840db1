"""NURBS evaluation and closest-point projection speed, against Open CASCADE in the same run.

Surface: bicubic rational 20 x 20 control points over [0, 1]^2 (fixed seed), waves of
curvature radius ~0.15 in a unit box. Measures

* points per second of ``surface_points`` and of ``surface_derivatives(n_derivs=2)``;
* 100k projections (``project_to_surface``) of points on the surface and of points off it
  along the normal (up to 1 % of the diagonal): seconds, max parameter error, converged share;
* Open CASCADE on a subset, scaled to per second: ``Geom_BSplineSurface.D0`` / ``D2`` in a Python
  loop (so its figures include the Python call overhead, ~1 us per call) and
  ``GeomAPI_ProjectPointOnSurf`` (initialised once, ``Perform`` per point).

Usage: python benchmarks/eval_speed.py [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time

import numpy as np

from trimsurf.geom import project_to_surface, surface_derivatives, surface_points, unit_normals

SEED = 20240601
N_CTRL = 20
DEGREE = 3
N_POINTS = 500_000        # evaluation, points only
N_DERIVS = 200_000        # evaluation with 2nd derivatives
N_PROJ = 100_000          # projections
N_OCC_EVAL = 20_000       # Open CASCADE D0 / D2 loop subset
N_OCC_PROJ = 2_000        # Open CASCADE projection subset
REPEATS = 3               # best of, for the vectorised trimsurf timings
NORMAL_OFFSET_REL = 0.01  # off-surface points: |offset| <= this x diagonal


def build_surface():
    rng = np.random.default_rng(SEED)
    g = np.linspace(0, 1, N_CTRL)
    cp = np.zeros((N_CTRL, N_CTRL, 3))
    cp[..., 0], cp[..., 1] = g[:, None], g[None, :]
    cp[..., 2] = 0.2 * np.sin(6 * g[:, None]) * np.cos(5 * g[None, :]) + 0.02 * rng.standard_normal((N_CTRL, N_CTRL))
    weights = rng.uniform(0.5, 2.0, (N_CTRL, N_CTRL))
    knots = np.r_[np.zeros(DEGREE), np.linspace(0, 1, N_CTRL - DEGREE + 1), np.ones(DEGREE)]
    return (DEGREE, DEGREE, knots, knots, cp, weights)


def best_time(fn, repeats=REPEATS):
    best, out = np.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def occ_surface(surf):
    from OCP.collections import Array1_double, Array1_int, Array2_double, Array2_gp_Pnt
    from OCP.Geom import Geom_BSplineSurface
    from OCP.gp import gp_Pnt

    pu, pv, ku, kv, cp, w = surf
    nu, nv = cp.shape[:2]
    poles = Array2_gp_Pnt(1, nu, 1, nv)
    weights = Array2_double(1, nu, 1, nv)
    for i in range(nu):
        for j in range(nv):
            poles.SetValue(i + 1, j + 1, gp_Pnt(*map(float, cp[i, j])))
            weights.SetValue(i + 1, j + 1, float(w[i, j]))
    arrays = []
    for kn in (ku, kv):
        vals, mults = np.unique(kn, return_counts=True)
        a, m = Array1_double(1, len(vals)), Array1_int(1, len(vals))
        for i, (x, k) in enumerate(zip(vals.tolist(), mults.tolist()), start=1):
            a.SetValue(i, x)
            m.SetValue(i, int(k))
        arrays.append((a, m))
    (uk, um), (vk, vm) = arrays
    return Geom_BSplineSurface(poles, weights, uk, vk, um, vm, pu, pv)


def run_occ(surf, uv, pts_on, pts_off, uv_off):
    from OCP.GeomAPI import GeomAPI_ProjectPointOnSurf
    from OCP.gp import gp_Pnt, gp_Vec

    s = occ_surface(surf)
    u_list, v_list = uv[:N_OCC_EVAL, 0].tolist(), uv[:N_OCC_EVAL, 1].tolist()
    p = gp_Pnt()
    t0 = time.perf_counter()
    for u, v in zip(u_list, v_list):
        s.D0(u, v, p)
    t_d0 = time.perf_counter() - t0
    d1u, d1v, d2u, d2v, d2uv = gp_Vec(), gp_Vec(), gp_Vec(), gp_Vec(), gp_Vec()
    t0 = time.perf_counter()
    for u, v in zip(u_list, v_list):
        s.D2(u, v, p, d1u, d1v, d2u, d2v, d2uv)
    t_d2 = time.perf_counter() - t0
    # agreement of the two evaluators on the subset (sanity: same surface)
    occ_pts = np.array([(lambda q: (q.X(), q.Y(), q.Z()))(s.Value(u, v)) for u, v in zip(u_list[:200], v_list[:200])])
    agree = float(np.abs(occ_pts - surface_points(*surf, uv[:200])).max())

    result = {}
    for name, pts, ref_uv in (("on", pts_on, uv), ("off", pts_off, uv_off)):
        proj = GeomAPI_ProjectPointOnSurf()
        proj.Init(s, 0.0, 1.0, 0.0, 1.0)
        sub = pts[:N_OCC_PROJ].tolist()
        found = np.full((len(sub), 2), np.nan)
        t0 = time.perf_counter()
        for i, (x, y, z) in enumerate(sub):
            proj.Perform(gp_Pnt(x, y, z))
            if proj.IsDone() and proj.NbPoints() > 0:
                found[i] = proj.LowerDistanceParameters()
        t_proj = time.perf_counter() - t0
        ok = np.all(np.isfinite(found), axis=1)
        result[name] = {"seconds_per_point": t_proj / len(sub), "found_share": float(ok.mean()),
                        "max_param_error": float(np.abs(found[ok] - ref_uv[:len(sub)][ok]).max())}
    return {"d0_points_per_s": N_OCC_EVAL / t_d0, "d2_points_per_s": N_OCC_EVAL / t_d2,
            "max_point_difference_vs_trimsurf": agree, "proj": result}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", metavar="FILE", help="also write the figures as JSON")
    parser.add_argument("--no-occ", action="store_true", help="skip the Open CASCADE comparison")
    args = parser.parse_args(argv)

    surf = build_surface()
    rng = np.random.default_rng(SEED + 1)
    uv_eval = rng.random((N_POINTS, 2))
    t_pts, _ = best_time(lambda: surface_points(*surf, uv_eval))
    t_d2, _ = best_time(lambda: surface_derivatives(*surf, uv_eval[:N_DERIVS], n_derivs=2))

    cp = surf[4].reshape(-1, 3)
    diag = float(np.linalg.norm(cp.max(0) - cp.min(0)))
    uv = rng.random((N_PROJ, 2))
    pts_on = surface_points(*surf, uv)
    uv_off = rng.uniform(0.02, 0.98, (N_PROJ, 2))
    d = surface_derivatives(*surf, uv_off, n_derivs=1)
    offset = rng.uniform(-NORMAL_OFFSET_REL, NORMAL_OFFSET_REL, (N_PROJ, 1)) * diag
    pts_off = d[0, 0] + offset * unit_normals(d[1, 0], d[0, 1])

    proj = {}
    for name, pts, ref in (("on", pts_on, uv), ("off", pts_off, uv_off)):
        t, pr = best_time(lambda pts=pts: project_to_surface(pts, *surf))
        proj[name] = {"seconds": t, "points_per_s": N_PROJ / t, "max_param_error": float(np.abs(pr.uv - ref).max()),
                      "converged_share": float(pr.converged.mean()), "iterations": int(pr.iterations)}

    figures = {
        "surface": f"bicubic rational {N_CTRL}x{N_CTRL}, seed {SEED}",
        "machine": {"cpus": os.cpu_count(), "python": platform.python_version(), "numpy": np.__version__},
        "eval_points_per_s": N_POINTS / t_pts,
        "eval_d2_points_per_s": N_DERIVS / t_d2,
        "projection": proj,
    }
    if not args.no_occ:
        figures["occt"] = run_occ(surf, uv, pts_on, pts_off, uv_off)

    rows = [("evaluate S (points/s)", figures["eval_points_per_s"], "d0_points_per_s"),
            ("evaluate S..S_vv (points/s)", figures["eval_d2_points_per_s"], "d2_points_per_s")]
    print(f"{'metric':38s} {'trimsurf':>12s} {'OCCT':>12s} {'ratio':>8s}")
    occ = figures.get("occt")
    for label, mine, key in rows:
        ref = occ[key] if occ else float("nan")
        print(f"{label:38s} {mine:12.3g} {ref:12.3g} {mine / ref:8.1f}")
    for name in ("on", "off"):
        p = proj[name]
        o = occ["proj"][name] if occ else None
        ref_rate = 1.0 / o["seconds_per_point"] if o else float("nan")
        label = f"project {N_PROJ // 1000}k pts {name} surface (points/s)"
        print(f"{label:38s} {p['points_per_s']:12.3g} {ref_rate:12.3g} {p['points_per_s'] / ref_rate:8.1f}")
        print(f"{'  seconds for ' + str(N_PROJ // 1000) + 'k':38s} {p['seconds']:12.3f} "
              f"{N_PROJ / ref_rate:12.3f}")
        print(f"{'  max parameter error':38s} {p['max_param_error']:12.2e} "
              f"{o['max_param_error'] if o else float('nan'):12.2e}")
        print(f"{'  converged (OCCT: found) share':38s} {p['converged_share']:12.4f} "
              f"{o['found_share'] if o else float('nan'):12.4f}")
    if occ:
        print(f"(OCCT: Python loop over {N_OCC_EVAL} evaluations and {N_OCC_PROJ} projections, scaled; "
              f"max |S_trimsurf - S_occt| = {occ['max_point_difference_vs_trimsurf']:.1e})")
    if args.json:
        with open(args.json, "w", encoding="utf-8") as fh:
            json.dump(figures, fh, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())

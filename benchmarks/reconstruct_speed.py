"""Reconstruction speed: minimum norm network solve and filling at 1K, 10K and 100K vertices.

Meshes: closed bumpy tori (regular grid triangulation, fixed shape, N ~ 1K, 10K, 100K
vertices). Runs the G1 network with the split filling (the default), the G2 network
with single degree-7 patches (1K and 10K; --g2-100k adds 100K), and the
Shirman-Séquin baseline, and Peters' single quintics (1K and 10K: its global sparse
least-squares solve is the slowest fill), each timed as network solve / filling / check
(check = G0, G1 and curvature jumps sampled at 17 points inside every patch edge).

Reference tool in the same run: scipy's CloughTocher2DInterpolator, whose global
gradient estimation is Nielson's functional minimum norm network (the 2N x 2N problem
this paper generalizes), on a height field with the same number of vertices; our
network is solved on the same triangulation in its functional setting, so the ratio
compares the two solvers of one system.

Usage: python benchmarks/reconstruct_speed.py [--json] [--sizes 1000 10000 100000]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time

import numpy as np
from scipy.interpolate import CloughTocher2DInterpolator

from trimsurf.model import TriMesh
from trimsurf.reconstruct import build_network, reconstruct_mesh


def torus(n_vertices: int) -> TriMesh:
    n = max(int(np.sqrt(3 * n_vertices)), 6)
    m = max(n_vertices // n, 6)
    u = np.linspace(0, 2 * np.pi, n, endpoint=False)
    v = np.linspace(0, 2 * np.pi, m, endpoint=False)
    U, V = np.meshgrid(u, v, indexing="ij")
    r = 1.0 + 0.15 * np.sin(3 * U) * np.cos(2 * V)
    P = np.stack([(3 + r * np.cos(V)) * np.cos(U), (3 + r * np.cos(V)) * np.sin(U), r * np.sin(V)], -1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(n), np.arange(m), indexing="ij")
    a, b = i * m + j, ((i + 1) % n) * m + j
    c, d = ((i + 1) % n) * m + (j + 1) % m, i * m + (j + 1) % m
    T = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    return TriMesh(P, T)


def height_field(n_vertices: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    p = rng.random((n_vertices, 2))
    z = np.sin(3 * p[:, 0]) * np.cos(2 * p[:, 1]) + p[:, 0] ** 2
    return p, z


def bench_reference(n_vertices: int) -> dict:
    p, z = height_field(n_vertices)
    t0 = time.perf_counter()
    ct = CloughTocher2DInterpolator(p, z, tol=1e-10, maxiter=100000)
    t_ct = time.perf_counter() - t0
    tri = ct.tri.simplices.astype(np.int64)
    a, b, c = p[tri[:, 0]], p[tri[:, 1]], p[tri[:, 2]]
    area = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    tri = np.where((area < 0)[:, None], tri[:, [0, 2, 1]], tri)
    mesh = TriMesh(np.c_[p, z], tri)
    t0 = time.perf_counter()
    net = build_network(mesh, kind="g1", direction="d1", length="l0", functional="arc-length", max_iterations=1,
                        initial_normals=np.tile([0.0, 0.0, 1.0], (n_vertices, 1)))
    t_ours = time.perf_counter() - t0
    grad = -net.normals[:, :2] / net.normals[:, 2:]
    return {"vertices": n_vertices, "scipy_clough_tocher_s": t_ct, "ours_functional_network_s": t_ours,
            "ratio_ours_over_scipy": t_ours / t_ct,
            "max_gradient_difference": float(np.abs(grad - ct.grad[:, 0, :]).max())}


def bench(n_vertices: int, network: str, fill: str) -> dict:
    mesh = torus(n_vertices)
    c0 = time.process_time()
    rec = reconstruct_mesh(mesh, network=network, fill=fill)
    cpu = time.process_time() - c0
    r = rec.report
    return {"vertices": mesh.n_vertices, "network": network, "fill": fill, "iterations": r["iterations"],
            "network_s": r["network_seconds"], "fill_s": r["fill_seconds"],
            "check_s": r["seconds"] - r["network_seconds"] - r["fill_seconds"], "total_s": r["seconds"],
            "cpu_s": cpu,
            "patches": r["patches"], "g1_angle_max_deg": r["g1_error_max_deg"],
            "curvature_jump_max": r["curvature_jump_max"]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--sizes", type=int, nargs="+", default=[1000, 10000, 100000])
    ap.add_argument("--g2-100k", action="store_true", help="also run the G2 network at sizes above 20K")
    args = ap.parse_args(argv)
    rows, refs = [], []
    for n in args.sizes:
        for network, fill in (("g1", "split"), ("shirman-sequin", "split"), ("g2", "single"), ("g1", "peters")):
            if network == "g2" and n > 20000 and not args.g2_100k:
                continue
            if fill == "peters" and n > 20000:
                continue
            rows.append(bench(n, network, fill))
            print(f"  {rows[-1]['vertices']:>7d} {network:15s} {fill:7s} network {rows[-1]['network_s']:7.2f} s  "
                  f"fill {rows[-1]['fill_s']:6.2f} s  total {rows[-1]['total_s']:7.2f} s", file=sys.stderr)
        refs.append(bench_reference(n))
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else None
    out = {"benchmark": "reconstruct_speed", "python": platform.python_version(), "machine": platform.machine(),
           "load_average_1min_at_end": load,
           "runs": rows, "reference": refs}
    if args.json:
        print(json.dumps(out, indent=2))
    else:
        print(f"{'vertices':>8} {'network':15} {'fill':7} {'iter':>4} {'network s':>9} {'fill s':>7} "
              f"{'check s':>7} {'total s':>8} {'cpu s':>7} {'G1 max deg':>10} {'k jump':>8}")
        for r in rows:
            print(f"{r['vertices']:>8} {r['network']:15} {r['fill']:7} {r['iterations']:>4} {r['network_s']:>9.2f} "
                  f"{r['fill_s']:>7.2f} {r['check_s']:>7.2f} {r['total_s']:>8.2f} {r['cpu_s']:>7.2f} "
                  f"{r['g1_angle_max_deg']:>10.1e} {r['curvature_jump_max']:>8.3g}")
        print()
        print(f"load average (1 min) at the end: {load}")
        print(f"{'vertices':>8} {'scipy CT s':>10} {'ours s':>8} {'ours/scipy':>10} {'max |grad diff|':>15}")
        for r in refs:
            print(f"{r['vertices']:>8} {r['scipy_clough_tocher_s']:>10.3f} {r['ours_functional_network_s']:>8.3f} "
                  f"{r['ratio_ours_over_scipy']:>10.2f} {r['max_gradient_difference']:>15.1e}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

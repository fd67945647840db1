"""Replay of `geom._pcurve_kernels.loop_polylines_kernel` on every trim segment of a file (issue 17, item 2;
s28-polylines): the kernel as it was (`_nurbs_kernels._curve_point` called per point, a copy compiled here)
against the current one (that helper written out), at (512, 2) points per segment (the measurement's fine
polygons), (32, 6) (the meshing's fronts) and (8, 2); bits compared, best of 15, old/new interleaved.

Usage: PYTHONPATH=$PWD/src python benchmarks/loop_polylines_replay.py gmsh__U_Joint_2.stp trimesh__featuretype.STEP
"""
import time, sys, gc
from pathlib import Path
import numpy as np
from numba import njit
from trimsurf.geom._nurbs_kernels import _curve_point
from trimsurf.geom._pcurve_kernels import loop_polylines_kernel as new
from trimsurf.io import read_shell
from trimsurf.tessellate.face import _loop_arrays

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "cad"

@njit(nogil=True)
def old(si, sf, ck, cpw, n_a, n_b, out_a, out_b):
    mp = 0
    for j in range(si.shape[0]):
        mp = max(mp, si[j, 0])
    ndu = np.empty((mp + 1, mp + 1)); aa = np.empty((2, mp + 1)); left = np.empty(mp + 1); right = np.empty(mp + 1)
    ders = np.empty((1, mp + 1)); row = np.empty(2)
    for j in range(si.shape[0]):
        p = si[j, 0]
        kc = ck[si[j, 1]:si[j, 1] + si[j, 2]]
        pw = cpw[si[j, 3]:si[j, 3] + si[j, 4] * si[j, 5]].reshape((si[j, 4], si[j, 5]))
        rational = si[j, 6] != 0
        lo, hi = kc[p], kc[kc.shape[0] - p - 1]
        t0, t1 = sf[j, 0], sf[j, 1]
        for which in range(2):
            n = n_a if which == 0 else n_b
            step = (t1 - t0) / (n - 1)
            for k in range(n - 1):
                if step == 0.0:
                    t = (k / (n - 1)) * (t1 - t0) + t0
                else:
                    t = k * step + t0
                t = min(max(t, lo), hi)
                _curve_point(p, kc, pw, rational, t, ndu, aa, left, right, ders, row)
                if which == 0:
                    out_a[j * (n - 1) + k, 0] = row[0]; out_a[j * (n - 1) + k, 1] = row[1]
                else:
                    out_b[j * (n - 1) + k, 0] = row[0]; out_b[j * (n - 1) + k, 1] = row[1]

for name in sys.argv[1:]:
    faces = list(read_shell(str(DATA / name)).faces)
    si, sf, ck, cpw, _, _ = _loop_arrays(faces)
    m = len(si)
    for na, nb in ((512, 2), (32, 6), (8, 2)):
        res = {}
        for key, fn in (("old", old), ("new", new)) * 1:
            oa, ob = np.empty((m * (na - 1), 2)), np.empty((m * (nb - 1), 2))
            fn(si, sf, ck, cpw, np.int64(na), np.int64(nb), oa, ob)
            res[key] = (oa.copy(), ob.copy())
        same = all(np.array_equal(res["old"][i].view(np.int64), res["new"][i].view(np.int64)) for i in range(2))
        t = {"old": 1e9, "new": 1e9}
        for _ in range(15):
            for key, fn in (("old", old), ("new", new)):
                oa, ob = np.empty((m * (na - 1), 2)), np.empty((m * (nb - 1), 2))
                c = time.perf_counter(); fn(si, sf, ck, cpw, np.int64(na), np.int64(nb), oa, ob)
                t[key] = min(t[key], time.perf_counter() - c)
        print(f"{name} segments {m} n=({na},{nb}) bits same {same}: old {t['old']*1e3:.2f} ms new {t['new']*1e3:.2f} ms ratio {t['new']/t['old']:.3f}", flush=True)

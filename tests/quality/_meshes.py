"""Meshes and surfaces built in code for the quality tests."""

from __future__ import annotations

import numpy as np

from trimsurf.model import Loop, NurbsCurve, NurbsSurface, PCurve, TriMesh, TrimmedFace

SPHERE_R = 2.0


def sphere_patch(radius: float = SPHERE_R) -> NurbsSurface:
    """Exact sphere patch (rational biquadratic): longitude 0..90 deg, latitude -45..45 deg, centre 0."""
    c = np.sqrt(0.5)
    profile = [(radius * c, -radius * c, 1.0), (radius / c, 0.0, c), (radius * c, radius * c, 1.0)]
    cp = np.zeros((3, 3, 3))
    w = np.zeros((3, 3))
    wu = [1.0, c, 1.0]
    for j, (r, z, wv) in enumerate(profile):
        for i, (x, y) in enumerate([(r, 0.0), (r, r), (0.0, r)]):
            cp[i, j] = (x, y, z)
            w[i, j] = wu[i] * wv
    k = [0, 0, 0, 1, 1, 1]
    return NurbsSurface(2, 2, k, k, cp, w)


def plane_patch() -> NurbsSurface:
    """The plane z = 1 over [0, 2] x [0, 1] as a biquadratic B-spline with an uneven knot
    (so (u, v) is not an affine image of (x, y) — a harder case than a bilinear patch)."""
    ku = [0, 0, 0, 0.3, 1, 1, 1]
    kv = [0, 0, 0, 1, 1, 1]
    # Greville abscissae give control points that reproduce x = 2 u, y = v exactly
    gu = np.array([0.0, 0.15, 0.65, 1.0])
    gv = np.array([0.0, 0.5, 1.0])
    cp = np.zeros((4, 3, 3))
    cp[..., 0] = 2 * gu[:, None]
    cp[..., 1] = gv[None, :]
    cp[..., 2] = 1.0
    return NurbsSurface(2, 2, ku, kv, cp)


def grid_mesh(surface: NurbsSurface, n: int, lo: float = 0.1, hi: float = 0.9) -> TriMesh:
    """n x n (u, v) grid on [lo, hi]^2 of the (unit-square-domain) surface, two triangles per cell, uv kept."""
    g = np.linspace(lo, hi, n)
    uu, vv = np.meshgrid(g, g, indexing="ij")
    uv = np.column_stack([uu.ravel(), vv.ravel()])
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    tris = np.vstack([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
    return TriMesh(surface.evaluate(uv), tris, uv=uv)


def lattice_mesh(surface: NurbsSurface, n: int, lo: float = 0.1, hi: float = 0.9) -> TriMesh:
    """Triangular lattice in (u, v) (odd rows shifted by half a step): acute triangles."""
    h = (hi - lo) / (n - 1)
    rows = [np.column_stack([np.minimum(lo + h * np.arange(n) + (0.5 * h if j % 2 else 0.0), hi),
                             np.full(n, lo + h * j)]) for j in range(n)]
    uv = np.vstack(rows)
    idx = np.arange(n * n).reshape(n, n)
    tris = []
    for j in range(n - 1):
        a, b = idx[j], idx[j + 1]
        if j % 2 == 0:
            tris += [np.column_stack([a[:-1], a[1:], b[:-1]]), np.column_stack([a[1:], b[1:], b[:-1]])]
        else:
            tris += [np.column_stack([a[:-1], b[1:], b[:-1]]), np.column_stack([a[:-1], a[1:], b[1:]])]
    return TriMesh(surface.evaluate(uv), np.vstack(tris), uv=uv)


def rect_face(surface: NurbsSurface, lo=(0.1, 0.1), hi=(0.9, 0.9), *, same_sense: bool = True,
              edge_ids=(-1, -1, -1, -1)) -> TrimmedFace:
    """Face trimmed to the (u, v) rectangle [lo, hi], counter-clockwise, straight p-curves."""
    c = [(lo[0], lo[1]), (hi[0], lo[1]), (hi[0], hi[1]), (lo[0], hi[1])]
    segs = tuple(PCurve(NurbsCurve(1, [0, 0, 1, 1], [c[i], c[(i + 1) % 4]]), 0.0, 1.0, edge_id=edge_ids[i])
                 for i in range(4))
    return TrimmedFace(surface, (Loop(segs),), same_sense=same_sense)


def icosphere(level: int, center=(0.0, 0.0, 0.0), radius: float = 1.0) -> TriMesh:
    """Closed, outward-oriented icosahedral sphere mesh (20 * 4**level triangles)."""
    t = (1 + 5 ** 0.5) / 2
    v = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t],
                  [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], dtype=float)
    f = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
                  [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9],
                  [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]])
    v /= np.linalg.norm(v, axis=1)[:, None]
    for _ in range(level):
        e = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
        u, inv = np.unique(e, axis=0, return_inverse=True)
        inv = inv.ravel()
        mid = v[u[:, 0]] + v[u[:, 1]]
        mid /= np.linalg.norm(mid, axis=1)[:, None]
        m = len(f)
        a, b, c = inv[:m] + len(v), inv[m:2 * m] + len(v), inv[2 * m:] + len(v)
        v = np.vstack([v, mid])
        f = np.vstack([np.column_stack([f[:, 0], a, c]), np.column_stack([f[:, 1], b, a]),
                       np.column_stack([f[:, 2], c, b]), np.column_stack([a, b, c])])
    return TriMesh(v * radius + np.asarray(center, dtype=float), f)


def torus(n_major: int = 24, n_minor: int = 12, r_major: float = 2.0, r_minor: float = 0.5) -> TriMesh:
    """Closed torus grid mesh (genus 1)."""
    a, b = np.meshgrid(np.arange(n_major), np.arange(n_minor), indexing="ij")
    th, ph = 2 * np.pi * a.ravel() / n_major, 2 * np.pi * b.ravel() / n_minor
    v = np.column_stack([(r_major + r_minor * np.cos(ph)) * np.cos(th),
                         (r_major + r_minor * np.cos(ph)) * np.sin(th), r_minor * np.sin(ph)])
    idx = np.arange(n_major * n_minor).reshape(n_major, n_minor)
    p, q = idx, np.roll(idx, -1, axis=0)
    r, s = np.roll(q, -1, axis=1), np.roll(p, -1, axis=1)
    tris = np.vstack([np.column_stack([p.ravel(), q.ravel(), r.ravel()]),
                      np.column_stack([p.ravel(), r.ravel(), s.ravel()])])
    return TriMesh(v, tris)


def flat_grid(n: int, *, rotate_seed: int | None = None) -> TriMesh:
    """Unit-square grid of 2 (n-1)^2 triangles in z = 0, optionally rotated rigidly in 3D."""
    x, y = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n), indexing="ij")
    v = np.column_stack([x.ravel(), y.ravel(), np.zeros(n * n)])
    if rotate_seed is not None:
        q, _ = np.linalg.qr(np.random.default_rng(rotate_seed).normal(size=(3, 3)))
        v = v @ q.T
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    return TriMesh(v, np.vstack([np.column_stack([a, b, c]), np.column_stack([a, c, d])]))


def circumradii(mesh: TriMesh) -> np.ndarray:
    p = mesh.vertices[mesh.triangles]
    a = np.linalg.norm(p[:, 1] - p[:, 2], axis=1)
    b = np.linalg.norm(p[:, 0] - p[:, 2], axis=1)
    c = np.linalg.norm(p[:, 0] - p[:, 1], axis=1)
    return a * b * c / (4 * mesh.triangle_areas())

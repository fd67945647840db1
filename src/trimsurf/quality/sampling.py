"""Sample points on a mesh (barycentric grids) and on a trimmed face (its (u, v) region).

Mesh samples: every used vertex once, every edge at ``j / density``
(``j = 1 .. density - 1``, plus its midpoint when `density` is odd) once,
and every triangle at the interior nodes of its barycentric grid of step
``1 / density`` (``(i, j, k) / density``, all of i, j, k >= 1). Shared vertices and
edges are sampled once, so the samples cover the mesh without repeats and
the grid's covering radius on a triangle is at most its circumradius divided
by `density`.

Face samples: an ``n x n`` grid over the (u, v) box of the outer loop (the
whole domain when the face is untrimmed), kept where inside the loops (even-odd
rule on the loops' polylines), plus the loop polylines themselves.
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import numpy as np

from ..errors import InputError
from ..geom.predicates import PolygonIndex, _points_in_polygons_kernel, points_in_polygons
from ..model import NurbsSurface, TriMesh, TrimmedFace
from ..model.trim import loops_polylines
from ._kernels import segments_distance_kernel

__all__ = ["TriangleSamples", "sample_triangles", "as_face", "loop_polygons", "inside_face",
           "distance_outside_face", "sample_face_domain"]


class TriangleSamples(NamedTuple):
    """Sample points of a mesh.

    Attributes
    ----------
    points : (k, 3) float64
    triangle : (k,) int64
        A triangle holding each sample.
    barycentric : (k, 3) float64
        Weights of that triangle's corners.
    kind : (k,) int8
        0 vertex, 1 edge, 2 triangle interior.
    element : (k,) int64
        The vertex (kind 0), edge of `TriMesh.edges()` (kind 1) or triangle (kind 2) sampled.
    """

    points: np.ndarray
    triangle: np.ndarray
    barycentric: np.ndarray
    kind: np.ndarray
    element: np.ndarray

    def incidence(self, mesh: TriMesh) -> tuple[np.ndarray, np.ndarray]:
        """Every (sample, triangle) pair where the triangle holds the sample, as two (p,) int64 arrays.

        A vertex sample belongs to all triangles around the vertex, an edge
        sample to the triangles on the edge, an interior sample to its triangle.
        """
        k0 = np.flatnonzero(self.kind == 0)
        k1 = np.flatnonzero(self.kind == 1)
        k2 = np.flatnonzero(self.kind == 2)
        vs = np.full(mesh.n_vertices, -1, dtype=np.int64)
        vs[self.element[k0]] = k0
        m = mesh.n_triangles
        tri3 = np.repeat(np.arange(m, dtype=np.int64), 3)
        s_v, t_v = vs[mesh.triangles.ravel()], tri3
        inv = mesh.half_edge_edges()
        n_edges = len(mesh.edges())
        ns = len(k1) // n_edges if n_edges else 0
        # edge samples are stored edge by edge, ns per edge, starting at k1[0]
        start = k1[0] if len(k1) else 0
        s_e = (start + inv[:, None] * ns + np.arange(ns)[None, :]).ravel()
        t_e = np.repeat(tri3, ns)
        return np.concatenate([s_v, s_e, k2]), np.concatenate([t_v, t_e, self.element[k2]])

    def per_triangle_max(self, mesh: TriMesh, values: np.ndarray) -> np.ndarray:
        """Largest of `values` (one per sample) over each triangle's samples, its vertices and edges included."""
        s, t = self.incidence(mesh)
        out = np.full(mesh.n_triangles, -np.inf)
        np.maximum.at(out, t, np.asarray(values, dtype=np.float64)[s])
        return out


def sample_triangles(mesh: TriMesh, *, density: int = 4) -> TriangleSamples:
    """Barycentric-grid samples of a mesh: vertices, edge points (midpoints included), interior nodes.

    Parameters
    ----------
    mesh : TriMesh
    density : int
        Grid divisions per edge (>= 1). Samples per triangle are about
        ``(density - 1) (density - 2) / 2 + 1.5 * max(density - 1, 1) + 0.5``.

    Returns
    -------
    TriangleSamples

    Raises
    ------
    InputError
        Not a TriMesh or density < 1.

    Examples
    --------
    >>> m = TriMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    >>> len(sample_triangles(m, density=4).points)  # 3 vertices + 3 * 3 edge points + 3 interior
    15
    """
    if not isinstance(mesh, TriMesh):
        raise InputError(f"sample_triangles needs a TriMesh; got {type(mesh).__name__}")
    density = int(density)
    if density < 1:
        raise InputError(f"density must be >= 1; got {density}")
    t = mesh.triangles
    m = len(t)
    # vertices: first corner that uses each vertex
    used, first = np.unique(t.ravel(), return_index=True)
    v_tri, v_corner = first // 3, first % 3
    v_w = np.zeros((len(first), 3))
    v_w[np.arange(len(first)), v_corner] = 1.0
    # edges: first half-edge of each undirected edge
    inv = mesh.half_edge_edges()
    _, first_he = np.unique(inv, return_index=True)
    e_tri, c0 = first_he // 3, first_he % 3
    c1 = (c0 + 1) % 3
    s, g_w = _density_nodes(density)
    ne, ns = len(first_he), len(s)
    e_w = np.zeros((ne, ns, 3))
    rows = np.arange(ne)[:, None]
    e_w[rows, np.arange(ns)[None, :], c0[:, None]] = 1.0 - s[None, :]
    e_w[rows, np.arange(ns)[None, :], c1[:, None]] = s[None, :]
    e_w = e_w.reshape(-1, 3)
    e_tri = np.repeat(e_tri, ns)
    i_w = np.tile(g_w, (m, 1))
    i_tri = np.repeat(np.arange(m), len(g_w))
    tri = np.concatenate([v_tri, e_tri, i_tri]).astype(np.int64)
    bary = np.concatenate([v_w, e_w, i_w])
    kind = np.concatenate([np.zeros(len(v_tri)), np.ones(len(e_tri)), np.full(len(i_tri), 2)]).astype(np.int8)
    element = np.concatenate([used, np.repeat(np.arange(ne), ns), i_tri]).astype(np.int64)
    p = mesh.vertices[t[tri]]
    points = np.einsum("kj,kjd->kd", bary, p)
    return TriangleSamples(points, tri, bary, kind, element)


@functools.lru_cache(maxsize=64)
def _density_nodes(density: int) -> tuple[np.ndarray, np.ndarray]:
    """`sample_triangles`' edge parameters s (midpoint included for an odd density) and interior nodes' weights
    (i, j, density - i - j) / density, built once per density (read-only; every face of a measurement asks
    for the same one)."""
    s = np.arange(1, density) / density
    if density % 2:
        s = np.sort(np.r_[s, 0.5])
    ij = np.array([(i, j) for i in range(1, density) for j in range(1, density - i) if density - i - j >= 1],
                  dtype=np.float64).reshape(-1, 2)
    g_w = np.column_stack([ij[:, 0], ij[:, 1], density - ij.sum(axis=1)]) / density
    for a in (s, g_w):
        a.flags.writeable = False
    return s, g_w


def as_face(target) -> TrimmedFace:
    """`target` as a TrimmedFace (a NurbsSurface becomes an untrimmed face)."""
    if isinstance(target, TrimmedFace):
        return target
    if isinstance(target, NurbsSurface):
        return TrimmedFace(target)
    raise InputError(f"expected a NurbsSurface or TrimmedFace; got {type(target).__name__}")


#: loop polygons of the last faces asked for, by (id(face), points per segment), the face kept alive in
#: the entry (so its id is not reused while cached): measuring a face asks for them several times
_POLYGONS: dict = {}
_POLYGONS_SIZE = 2048
#: the slab index of `points_in_polygons` per polygon list of `_POLYGONS` (by the list's id, kept alive)
_SLABS: dict = {}


def loop_polygons(face: TrimmedFace, *, n_per_segment: int = 32) -> list[np.ndarray]:
    """The face's loops as (k, 2) polygons in (u, v); the domain rectangle when untrimmed.

    The arrays are read-only and shared between calls on the same face (the list is a fresh copy)."""
    return list(_loop_polygons(face, int(n_per_segment)))


def _loop_polygons(face: TrimmedFace, n_per_segment: int) -> tuple:
    key = (id(face), n_per_segment)
    hit = _POLYGONS.get(key)
    if hit is not None and hit[0] is face:
        return hit[1]
    if face.loops:
        polys = loops_polylines(face.loops, n_per_segment)      # one compiled call for all loops
    else:
        (u0, u1), (v0, v1) = face.surface.domain
        polys = [np.array([[u0, v0], [u1, v0], [u1, v1], [u0, v1]], dtype=np.float64)]
    for p in polys:
        p.flags.writeable = False
    polys = tuple(polys)
    if len(_POLYGONS) >= _POLYGONS_SIZE:
        old = _POLYGONS.pop(next(iter(_POLYGONS)))
        _SLABS.pop(id(old[1]), None)
    _POLYGONS[key] = (face, polys)
    return polys


def _inside_loops(face: TrimmedFace, uv: np.ndarray, n_per_segment: int = 32) -> np.ndarray:
    """`points_in_polygons(uv, loop_polygons(face, n_per_segment))` with the polygons' slab index built
    once per face (the same index and kernel, so the same answers)."""
    polys = _loop_polygons(face, int(n_per_segment))
    hit = _SLABS.get(id(polys))
    if hit is None or hit[0] is not polys:
        hit = (polys, _slab_index(polys))
        _SLABS[id(polys)] = hit
    pts = np.ascontiguousarray(np.atleast_2d(np.asarray(uv, dtype=np.float64)).reshape(-1, 2))
    inside = np.zeros(len(pts), dtype=bool)
    a, b, y0, h, n_slab, start, edges = hit[1]
    if not len(pts) or not len(a):
        return inside
    _points_in_polygons_kernel(pts, a, b, y0, h, n_slab, start, edges, inside)
    return inside


def _slab_index(polygons) -> tuple:
    """The edges and horizontal slabs `geom.predicates.points_in_polygons` builds: (a, b, y0, h, n_slab,
    start, edges) of its `PolygonIndex` (compiled, one call per polygon list; the same arrays as
    `_slab_index_numpy`, the former numpy version, kept as the reference of the tests)."""
    index = PolygonIndex(polygons)
    if not len(index.a):
        a = index.a
        return a, a.copy(), 0.0, 1.0, 1, np.zeros(2, dtype=np.int64), np.zeros(0, dtype=np.int64)
    return index.a, index.b, float(index.y0), float(index.h), int(index.n_slab), index.start, index.edges


def _slab_index_numpy(polygons) -> tuple:
    """`_slab_index` in numpy (the reference its tests compare with)."""
    a = np.ascontiguousarray(np.concatenate([np.asarray(p, dtype=np.float64) for p in polygons]))
    b = np.ascontiguousarray(np.concatenate([np.roll(np.asarray(p, dtype=np.float64), -1, axis=0)
                                             for p in polygons]))
    if not len(a):
        return a, b, 0.0, 1.0, 1, np.zeros(2, dtype=np.int64), np.zeros(0, dtype=np.int64)
    ylo = np.minimum(a[:, 1], b[:, 1])
    yhi = np.maximum(a[:, 1], b[:, 1])
    y0, y1 = float(ylo.min()), float(yhi.max())
    n_slab = int(min(max(1, len(a)), 1 << 16))
    while True:
        h = (y1 - y0) / n_slab if y1 > y0 else 1.0
        first = np.clip(((ylo - y0) / h).astype(np.int64), 0, n_slab - 1)
        last = np.clip(((yhi - y0) / h).astype(np.int64), 0, n_slab - 1)
        cnt = last - first + 1
        if n_slab == 1 or int(cnt.sum()) <= 8 * len(a) + (1 << 16):
            break
        n_slab //= 4
    edge = np.repeat(np.arange(len(a)), cnt)
    slab = np.repeat(first, cnt) + (np.arange(cnt.sum()) - np.repeat(np.cumsum(cnt) - cnt, cnt))
    order = np.argsort(slab, kind="stable")
    start = np.searchsorted(slab[order], np.arange(n_slab + 1))
    return (a, b, y0, h, n_slab, np.ascontiguousarray(start, dtype=np.int64),
            np.ascontiguousarray(edge[order], dtype=np.int64))


def inside_face(face: TrimmedFace, uv, *, n_per_segment: int = 32) -> np.ndarray:
    """Whether (u, v) points (n, 2) lie in the face's trimmed region (all True when untrimmed)."""
    uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
    if not face.loops:
        return np.ones(len(uv), dtype=bool)
    return _inside_loops(face, uv, n_per_segment)


def distance_outside_face(face: TrimmedFace, uv, *, n_per_segment: int = 32,
                          chunk_size: int = 1 << 22) -> np.ndarray:
    """Distance in (u, v) from each point (n, 2) to the face's trimmed region, 0 inside, shape (n,).

    Compiled, point by point (`chunk_size`, the memory bound of the former array version, is not used)."""
    uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
    out = np.zeros(len(uv))
    polys = loop_polygons(face, n_per_segment=n_per_segment)
    if face.loops:
        outside = np.flatnonzero(~_inside_loops(face, uv, n_per_segment))
    else:
        (u0, u1), (v0, v1) = face.surface.domain
        outside = np.flatnonzero((uv[:, 0] < u0) | (uv[:, 0] > u1) | (uv[:, 1] < v0) | (uv[:, 1] > v1))
    if not outside.size:
        return out
    a = np.ascontiguousarray(np.concatenate(polys))
    b = np.ascontiguousarray(np.concatenate([np.roll(p, -1, axis=0) for p in polys]))
    d = np.empty(outside.size)
    segments_distance_kernel(np.ascontiguousarray(uv[outside]), a, b, d)
    out[outside] = d
    return out


def sample_face_domain(face, *, n: int = 64, n_per_segment: int = 32) -> np.ndarray:
    """(u, v) samples of a face's trimmed region: grid points inside plus the loop polylines, (k, 2).

    Parameters
    ----------
    face : TrimmedFace or NurbsSurface
    n : int or (int, int)
        Grid points per direction (or in u and in v) over the (u, v) box of the outer loop (>= 2).
    n_per_segment : int
        Points per loop segment (>= 2).

    Raises
    ------
    InputError
        Wrong type or n < 2.
    """
    face = as_face(face)
    nu, nv = (int(n), int(n)) if np.ndim(n) == 0 else (int(n[0]), int(n[1]))
    n_per_segment = int(n_per_segment)
    if min(nu, nv) < 2 or n_per_segment < 2:
        raise InputError(f"n and n_per_segment must be >= 2; got {n}, {n_per_segment}")
    polys = loop_polygons(face, n_per_segment=n_per_segment)
    lo, hi = polys[0].min(axis=0), polys[0].max(axis=0)
    (du0, du1), (dv0, dv1) = face.surface.domain
    lo = np.maximum(lo, [du0, dv0])
    hi = np.minimum(hi, [du1, dv1])
    # the rows of ``np.meshgrid(lu, lv, indexing="ij")`` raveled: u major (the same values, fewer calls)
    grid = np.empty((nu * nv, 2))
    grid[:, 0] = np.repeat(np.linspace(lo[0], hi[0], nu), nv)
    grid[:, 1] = np.tile(np.linspace(lo[1], hi[1], nv), nu)
    if face.loops:
        grid = grid[_inside_loops(face, grid, n_per_segment)]
        boundary = np.concatenate(polys)
        boundary = np.clip(boundary, [du0, dv0], [du1, dv1])
        return np.concatenate([grid, boundary])
    return grid

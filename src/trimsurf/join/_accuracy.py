"""Deviation of joined triangles from their face, measured inside the triangles (not only at the vertices).

The paper bounds the height eta at the mesh vertices (Sec. II, Sec. III-A); between the vertices a flat
triangle also departs from a curved surface by its chord error. The join keeps that error below a
tolerance: the external region Triangle adds is refined (Ruppert refinement with area limits, so the
angle bound of Sec. III-B still holds) until every triangle's sampled deviation is within it.

`triangle_deviation` samples each triangle on a barycentric grid (corners, edge points, interior) and
takes for each sample an upper bound of its distance to the surface: |X - F(p)|, p the sample's linearly
interpolated (u, v). Samples whose bound exceeds `exact_above` are projected onto the surface (Gauss-Newton
from p; the distance found is to a point of the surface, so still an upper bound of the true distance,
and equal to it at the closest point). The per-triangle maxima are sampled figures: between the samples
the deviation may be larger by the grid's covering radius times the surface slope (quadratically small
near a smooth interior maximum).
"""

from __future__ import annotations

import numpy as np

from ..model import Shell, TriMesh, TrimmedFace

__all__ = ["barycentric_grid", "triangle_deviation", "faces_deviation", "mesh_deviation_inside", "input_deviation"]


def barycentric_grid(density: int) -> np.ndarray:
    """All barycentric weights (i, j, k) / density with i + j + k = density, (s, 3).

    Examples
    --------
    >>> barycentric_grid(2).shape
    (6, 3)
    """
    d = int(density)
    out = [(i, j, d - i - j) for i in range(d + 1) for j in range(d + 1 - i)]
    return np.array(out, dtype=np.float64) / d


def triangle_deviation(face: TrimmedFace, points: np.ndarray, uv: np.ndarray, triangles: np.ndarray, *,
                       density: int = 4, exact_above: float = 0.0, skip_edges: np.ndarray | None = None,
                       chunk: int = 200_000) -> np.ndarray:
    """Largest sampled distance to `face`'s surface of each triangle, (m,).

    Parameters
    ----------
    face : TrimmedFace
    points : (n, 3) vertex positions; uv : (n, 2) their parameters on the face (warm starts).
    triangles : (m, 3) int
    density : int
        Barycentric grid divisions per edge (4: 15 samples per triangle, corners and edge midpoints included).
    exact_above : float
        Samples whose upper bound |X - F(p)| is at most this keep the bound; the others are projected.
    skip_edges : (m, 3) bool, optional
        Leave out the samples on edge c (corners c and c + 1, its ends included) where True.

    Examples
    --------
    >>> from trimsurf.model import NurbsSurface, TrimmedFace
    >>> plane = NurbsSurface(1, 1, [0, 0, 1, 1], [0, 0, 1, 1],
    ...                      [[[0, 0, 0], [0, 1, 0]], [[1, 0, 0], [1, 1, 0]]])
    >>> p = np.array([[0, 0, 0.1], [1, 0, 0.1], [0, 1, 0.1]])
    >>> float(np.round(triangle_deviation(TrimmedFace(plane), p, p[:, :2], np.array([[0, 1, 2]]))[0], 12))
    0.1
    """
    from ._patch import project_near

    t = np.asarray(triangles, dtype=np.int64)
    m = len(t)
    out = np.zeros(m)
    if not m:
        return out
    b = barycentric_grid(density)
    s = len(b)
    step = max(1, chunk // s)
    for k in range(0, m, step):
        tt = t[k:k + step]
        x = np.einsum("sj,mjd->msd", b, points[tt]).reshape(-1, 3)
        p = np.einsum("sj,mjd->msd", b, uv[tt]).reshape(-1, 2)
        d = np.linalg.norm(x - face.surface.evaluate(p), axis=1)
        far = d > exact_above
        if far.any():
            pr = project_near(face, x[far], p[far], spacing=8.0 * float(d[far].max()) + 1e-300)
            d[far] = np.minimum(d[far], pr.distance)
        d = d.reshape(len(tt), s)
        if skip_edges is not None:
            sk = skip_edges[k:k + step]
            for c in range(3):   # on edge c the weight of the opposite corner is 0
                on = b[:, (c + 2) % 3] == 0
                d[np.ix_(sk[:, c], on)] = 0.0
        out[k:k + step] = d.max(axis=1)
    return out


def faces_deviation(shell: Shell, face_meshes, *, density: int = 6) -> dict:
    """The deviation of per-face meshes (``face_meshes[i]`` on ``shell.faces[i]``, None to skip), inside the triangles.

    Every mesh is sampled on a barycentric grid of `density` per edge (corners, edge points with midpoints,
    centroids for density divisible by 6) and each sample projected exactly onto its face's surface
    (`trimsurf.quality.surface_deviation`, warm-started from the mesh's uv when it has them). Returns
    ``max_deviation`` (sampled), ``p99_deviation`` (99th percentile of the per-triangle maxima),
    ``worst_face`` and ``per_face`` maxima.
    """
    from ..quality import surface_deviation

    per_face, per_tri = [], []
    for face, m in zip(shell.faces, face_meshes):
        if m is None or m.n_triangles == 0:
            per_face.append(None)
            continue
        dev = surface_deviation(m, face, density=density, two_sided=False)
        per_face.append(float(dev.max_mesh_to_target))
        per_tri.append(dev.per_triangle_max)
    if not per_tri:
        return {"max_deviation": None, "p99_deviation": None, "worst_face": None, "per_face": per_face,
                "deviation_samples_per_edge": int(density)}
    worst = int(np.argmax([-1.0 if d is None else d for d in per_face]))
    all_tri = np.concatenate(per_tri)
    return {"max_deviation": float(per_face[worst]), "p99_deviation": float(np.percentile(all_tri, 99)),
            "worst_face": worst, "per_face": per_face, "deviation_samples_per_edge": int(density)}


def mesh_deviation_inside(mesh: TriMesh, shell: Shell, *, density: int = 6, uv_of=None) -> dict:
    """`faces_deviation` of a mesh with ``face_id`` (its triangles of face i measured against face i).

    `uv_of`, optional: ``uv_of[i]`` (n, 2) the parameters of every mesh vertex on face i (NaN where
    unknown), used as warm starts only.
    """
    subs = []
    for i in range(len(shell.faces)):
        sel = mesh.face_id == i
        if not sel.any():
            subs.append(None)
            continue
        t = mesh.triangles[sel]
        used = np.unique(t)
        remap = np.full(mesh.n_vertices, -1, dtype=np.int64)
        remap[used] = np.arange(len(used))
        uv = None if uv_of is None or uv_of[i] is None else uv_of[i][used]
        if uv is not None and not np.all(np.isfinite(uv)):
            uv = None
        subs.append(TriMesh(mesh.vertices[used], remap[t], uv=uv))
    return faces_deviation(shell, subs, density=density)


def input_deviation(shell: Shell, meshes, *, density: int = 4, faces=None) -> float:
    """Largest sampled deviation (inside the triangles) of the per-face input meshes from their faces.

    `faces`: only these faces' meshes (default all).
    """
    keep = [m if (m.n_triangles and (faces is None or i in faces)) else None for i, m in enumerate(meshes)]
    dev = faces_deviation(shell, keep, density=density)["max_deviation"]
    return 0.0 if dev is None else float(dev)

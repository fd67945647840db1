"""The whole method (Fig. 2): B-rep of M, phi, W, S, trims -> a `TrimmedFace`, and its quality figures."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from ..errors import InputError
from ..model import TriMesh, TrimmedFace
from ._backmap import BACKMAPS, BackMap, backmap
from ._brep import MeshBRep, mesh_brep
from ._embed import EMBEDDINGS, EmbeddingQuality, embed, embedding_quality
from ._grid import ParameterGrid, parameter_grid
from ._trim import order_loops, trim_loops

__all__ = ["FitResult", "fit_trimmed_face", "FitQuality", "fit_quality", "evaluated_face_mesh"]


@dataclass(frozen=True, eq=False)
class FitResult:
    """A trimmed face F = (S, {L_0, ..., L_m}) fitted to a mesh M, with what led to it.

    Attributes
    ----------
    face : TrimmedFace
        S (NURBS on the grid W's rectangle) and the loops lambda_i (outer first).
    uv : (n, 2) float64
        U = phi(X), the parameters of the mesh vertices in S's domain.
    brep : MeshBRep
    embedding : EmbeddingQuality
        Flips and boundary crossings of phi, its length distortion, the mesh's curvature.
    backmap : BackMap
    grid : ParameterGrid
    embed_method, backmap_method : str
    seconds : dict
        Time of each step (s).
    """

    face: TrimmedFace
    uv: np.ndarray
    brep: MeshBRep
    embedding: EmbeddingQuality
    backmap: BackMap
    grid: ParameterGrid
    embed_method: str
    backmap_method: str
    seconds: dict = field(default_factory=dict)

    def mesh_uv(self, mesh: TriMesh) -> TriMesh:
        """`mesh` with uv = phi(X)."""
        return TriMesh(mesh.vertices, mesh.triangles, uv=self.uv)

    def to_table(self) -> list[dict]:
        """The report as a one-row table (a list with one flat dict) that ``pandas.DataFrame`` accepts."""
        from ..viz._notebook import report_table  # viz is a higher layer: imported on use only
        return report_table(self)

    def _repr_html_(self) -> str:
        """Jupyter: the interactive viewer inline (offline) and the report's key figures."""
        from ..viz._notebook import repr_html
        return repr_html(self)


def fit_trimmed_face(mesh: TriMesh, *, embed_method: str = "hlle", backmap_method: str = "lsq",
                     grid_shape: tuple[int, int] | None = None, trim_degree: int = 1, name: str = "fit",
                     uv: np.ndarray | None = None, progress=None, backmap_options: dict | None = None,
                     normalize_uv: bool = True) -> FitResult:
    """Fit a trimmed NURBS face to a disk-like mesh with holes (the paper's Fig. 2 pipeline).

    Parameters
    ----------
    mesh : TriMesh
        M: a connected, consistently oriented 2-manifold with boundary and
        genus 0 (a disk with holes).
    embed_method : {"hlle", "isomap", "laplacian", "lscm", "harmonic"}
        The forward map phi (Sec. 4.1; lscm and harmonic are beyond the paper).
    backmap_method : {"lsq", "hybrid", "rbf", "nurbs", "greville"}
        The back-map S (Sec. 4.2; see `trimsurf.fit.backmap`).
    grid_shape : (nu, nv) or None
        Control points of S (the grid W); None derives it from the mesh.
    trim_degree : {1, 3}
        p-curves as polylines (1) or least-squares cubics (3).
    name : str
        Face name (and error messages).
    uv : (n, 2) float64 or None
        A given parameterization U instead of computing phi (e.g. the exact
        flat layout of a developable mesh); it is normalised the same way.
    normalize_uv : bool
        False for a `uv` that `embed` returned with `embed_method` (already
        normalised): it is used as is and the result keeps `embed_method`'s
        name (instead of "given").
    progress : callable or None
        Called with the name of each step as it starts.
    backmap_options : dict or None
        Keyword options of the back-map (e.g. ``{"extrapolation_degree": 1}``
        for ``nurbs``).

    Returns
    -------
    FitResult

    Raises
    ------
    InputError
        Non-manifold, not disk-like, degenerate or disconnected meshes (see
        `mesh_brep`), unknown methods, a grid smaller than 4 x 4.

    Examples
    --------
    >>> from trimsurf.samples import holed_sheet
    >>> r = fit_trimmed_face(holed_sheet(max_area=600.0), embed_method="lscm", grid_shape=(10, 8))
    >>> len(r.face.loops), r.embedding.n_flipped
    (3, 0)
    """
    if embed_method not in EMBEDDINGS:
        raise InputError(f"unknown forward map {embed_method!r}; expected one of {', '.join(EMBEDDINGS)}")
    if backmap_method not in BACKMAPS:
        raise InputError(f"unknown back-map {backmap_method!r}; expected one of {', '.join(BACKMAPS)}")
    if trim_degree not in (1, 3):
        raise InputError(f"trim_degree must be 1 or 3; got {trim_degree!r}")
    tell = progress or (lambda _s: None)
    secs = {}
    t = time.perf_counter()
    tell("B-rep")
    brep = mesh_brep(mesh, name=name)
    secs["brep"] = time.perf_counter() - t
    t = time.perf_counter()
    tell(f"forward map ({embed_method})")
    if uv is None:
        U = embed(mesh, embed_method, brep=brep)
    elif normalize_uv:
        from ._embed import normalize_parameters
        U = normalize_parameters(mesh, uv)
        embed_method = "given"
    else:
        U = np.ascontiguousarray(uv, dtype=np.float64)
        if U.shape != (mesh.n_vertices, 2) or not np.all(np.isfinite(U)):
            raise InputError(f"uv must be finite with shape ({mesh.n_vertices}, 2); got {U.shape}")
    quality = embedding_quality(mesh, U, brep)
    secs["embed"] = time.perf_counter() - t
    t = time.perf_counter()
    tell(f"back-map ({backmap_method})")
    t_uv = U[mesh.triangles]
    e1, e2 = t_uv[:, 1] - t_uv[:, 0], t_uv[:, 2] - t_uv[:, 0]
    uv_area = 0.5 * float(np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum())
    grid = parameter_grid(U, grid_shape, n_vertices=mesh.n_vertices, area=uv_area)
    S = backmap(mesh, U, grid, backmap_method, **(backmap_options or {}))
    secs["backmap"] = time.perf_counter() - t
    t = time.perf_counter()
    tell("trim loops")
    loops_uv, _ = order_loops([U[lp] for lp in brep.loops])
    loops = trim_loops(loops_uv, degree=trim_degree, name=name)
    diag = mesh.diagonal()
    face = TrimmedFace(S.surface, loops, same_sense=True, name=name, tolerance=1e-7 * diag)
    secs["trim"] = time.perf_counter() - t
    return FitResult(face, U, brep, quality, S, grid, embed_method, backmap_method, secs)


def _subdivide(uv: np.ndarray, tris: np.ndarray, levels: int) -> tuple[np.ndarray, np.ndarray]:
    """Midpoint (1-to-4) subdivision of a 2D triangulation, `levels` times."""
    for _ in range(levels):
        n = len(uv)
        e = np.sort(np.stack([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]], axis=1).reshape(-1, 2), axis=1)
        key = e[:, 0] * n + e[:, 1]
        uniq, inv = np.unique(key, return_inverse=True)
        mids = 0.5 * (uv[uniq // n] + uv[uniq % n])
        m = (n + inv).reshape(-1, 3)                    # midpoints of edges (01, 12, 20)
        a, b, c = tris[:, 0], tris[:, 1], tris[:, 2]
        tris = np.concatenate([np.c_[a, m[:, 0], m[:, 2]], np.c_[m[:, 0], b, m[:, 1]],
                               np.c_[m[:, 2], m[:, 1], c], np.c_[m[:, 0], m[:, 1], m[:, 2]]])
        uv = np.vstack([uv, mids])
    return uv, tris


def evaluated_face_mesh(result: FitResult, mesh: TriMesh, *, levels: int = 1, use_nurbs: bool = False) -> TriMesh:
    """The trimmed face evaluated on the mesh's own parameter triangulation, subdivided `levels` times.

    S(phi(M)) sampled this way covers exactly the region the trim loops
    lambda_i bound (they are the border of the parameter triangulation).
    With ``use_nurbs`` the NURBS is evaluated even for the ``rbf`` back-map.
    """
    uv, tris = _subdivide(result.uv, mesh.triangles, levels)
    f = result.face.surface.evaluate if use_nurbs else result.backmap.evaluate
    return TriMesh(f(uv), tris, uv=uv)


@dataclass(frozen=True)
class FitQuality:
    """Distances between the mesh and the fitted trimmed face (model units) and their ratio to the diagonal.

    hausdorff : two-sided sampled Hausdorff distance, mesh vs trimmed face.
    rms_deviation : RMS of the mesh -> face distances of the samples.
    boundary_deviation : two-sided distance between the mesh boundary dM and the trim curves L_i = S(lambda_i)
        (all loops together, both sampled densely: 8 points per boundary edge and per p-curve control point).
    self_intersections_in_face : pairs of intersecting triangles of the evaluated face.
    """

    hausdorff: float
    rms_deviation: float
    boundary_deviation: float
    self_intersections_in_face: int
    diagonal: float
    hausdorff_rel: float
    rms_rel: float
    seconds: float


def _polyline_samples(p: np.ndarray, step: float, max_per_segment: int = 256) -> np.ndarray:
    q = np.roll(p, -1, axis=0)
    n = np.clip(np.ceil(np.linalg.norm(q - p, axis=1) / step), 1, max_per_segment).astype(np.int64)
    idx = np.repeat(np.arange(len(p)), n)
    t = (np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)) / np.repeat(n, n)
    return p[idx] + t[:, None] * (q[idx] - p[idx])


def _distance_to_polylines(points: np.ndarray, polylines: list[np.ndarray], k: int = 8) -> np.ndarray:
    """Distance of each point to the nearest of the closed polylines (exact point-segment distance over the k
    segments with the nearest midpoints)."""
    from ..quality import point_segment_closest

    a = np.concatenate(polylines)
    b = np.concatenate([np.roll(p, -1, axis=0) for p in polylines])
    k = min(k, len(a))
    _, idx = cKDTree(0.5 * (a + b)).query(points, k=k)
    idx = idx.reshape(len(points), k)
    q = np.repeat(points, k, axis=0)
    c, _ = point_segment_closest(q, a[idx.ravel()], b[idx.ravel()])
    return np.linalg.norm(c - q, axis=1).reshape(len(points), k).min(axis=1)


def fit_quality(result: FitResult, mesh: TriMesh, *, density: int | None = None, levels: int | None = None,
                self_intersections: bool = True) -> FitQuality:
    """In-memory diagnostic: Hausdorff, RMS and boundary deviation of the back-map S from the mesh before writing.

    Not the figures of the written face: S is evaluated on the mesh's own
    parameter triangulation, so the trims never enter it (the ``rbf``
    back-map's S is the RBF, not the B-spline written); the face as written is
    measured by `trimsurf.fit.measure_written_face`. The face is evaluated on
    the subdivided parameter triangulation
    (`evaluated_face_mesh`) and compared with the mesh by
    `trimsurf.quality.mesh_deviation` (exact closest points on triangles,
    `density` samples per triangle edge, both ways).
    """
    from ..quality import mesh_deviation
    from ..quality import self_intersections as self_int

    t = time.perf_counter()
    n = mesh.n_vertices
    if levels is None:
        levels = 1 if n <= 20000 else 0
    if density is None:
        density = 3 if n <= 5000 else 2
    fm = evaluated_face_mesh(result, mesh, levels=levels)
    dev = mesh_deviation(mesh, fm, density=density)
    diag = mesh.diagonal()
    # boundary: dM vs the trim curves L_i = S(lambda_i(t)) of the face's p-curves (densely sampled polylines)
    v = mesh.vertices
    mesh_loops = [v[lp] for lp in result.brep.loops]
    trim_loops_3d = [result.backmap.evaluate(np.concatenate(
        [seg.evaluate(seg.parameters(8 * seg.curve.n_control_points))[:-1] for seg in loop.segments]))
        for loop in result.face.loops]
    step = min(float(np.linalg.norm(np.roll(p, -1, axis=0) - p, axis=1).mean()) for p in mesh_loops) / 4
    a = np.concatenate([_polyline_samples(p, step) for p in mesh_loops])
    b = np.concatenate([_polyline_samples(p, step) for p in trim_loops_3d])
    bd = [float(_distance_to_polylines(a, trim_loops_3d).max()), float(_distance_to_polylines(b, mesh_loops).max())]
    n_si = -1
    if self_intersections:
        n_si = int(self_int(evaluated_face_mesh(result, mesh, levels=0)).n_pairs)
    return FitQuality(float(dev.max_two_sided), float(dev.rms_mesh_to_target), float(max(bd)), n_si, diag,
                      float(dev.max_two_sided / diag), float(dev.rms_mesh_to_target / diag),
                      time.perf_counter() - t)

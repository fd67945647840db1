"""The written face measured: the STEP file read back through Open CASCADE and compared with the mesh.

What a fit reports must be what a user opens. `measure_written_face` reads
the file with Open CASCADE's STEP reader and measures the face as read:

* ``step_valid``: ``BRepCheck_Analyzer`` on the shape read back (not on the
  shape before writing);
* ``area``: the trimmed face's area by ``BRepGProp::SurfaceProperties``
  (adaptive Gauss integration over the region inside the trims), and its
  ratio to the mesh's area;
* a tessellation of the trimmed face by ``BRepMesh_IncrementalMesh`` at a
  deflection tied to the tolerance (`deflection_for`), and no finer than
  1e-3 of the square root of the face's area (so a runaway face does not
  get millions of triangles);
* ``hausdorff_face_to_mesh``: exact distances to the mesh of points of the
  read-back surface S(u, v) at the tessellation's (u, v) nodes and triangle
  centroids, on a (u, v) grid of about the sample spacing in 3D kept where
  it falls on the face, and along the trim curves S(lambda) (the p-curves
  read back) at a quarter of the mesh's mean border edge;
* ``hausdorff_mesh_to_face``: each mesh vertex to the
  tessellation, then projected onto S from there (Newton from the
  tessellation's (u, v)); the projection is kept where its foot lies in the
  tessellated region (Open CASCADE's reading of the face) or, for a face
  BRepCheck accepts, inside its trim loops (even-odd); a foot outside
  is replaced by the nearest point q of the trim loops (the p-curves read
  back) in (u, v) and the distance to S(q) (an upper bound, exact for a mesh
  border vertex on the trim); the smaller of that and the tessellation's
  distance is kept;
* ``self_intersections``: intersecting triangle pairs of the tessellation
  (sheets of the face closer than the deflection may count).

The maxima are sampled, not proven: between samples a distance can exceed
the sampled maximum by up to the sample spacing (both reported). The sample
counts follow the face's area over the spacing squared and the mesh's vertex
and triangle counts (linear), never their product.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..model import TriMesh

__all__ = ["WrittenFace", "measure_written_face", "deflection_for"]


@dataclass(frozen=True, eq=False)
class WrittenFace:
    """Figures of the face read back from a STEP file, against the mesh it was fitted to (model units).

    Attributes
    ----------
    path : str
    readable : bool
        Open CASCADE read a shape with at least one face.
    n_faces : int
    step_valid : bool
        ``BRepCheck_Analyzer`` accepts the shape read back.
    area, mesh_area, area_ratio : float
        Trimmed face area (BRepGProp), mesh area, face / mesh.
    hausdorff : float
        max of the two one-sided maxima below (sampled).
    hausdorff_mesh_to_face, hausdorff_face_to_mesh : float
    rms_mesh_to_face : float
        RMS over the mesh samples.
    where_mesh_to_face, where_face_to_mesh : (3,) float64
        Where each maximum was found.
    boundary_deviation : float
        Two-sided distance between the mesh's boundary loops and the face's
        trim curves S(lambda) (its p-curves read back, mapped by S), both
        sampled at about a quarter of the mesh's mean boundary edge.
    self_intersections : int
        Intersecting triangle pairs of the tessellation of the face; -1 when
        not counted (a runaway face, see `RUNAWAY_AREA_RATIO`, or a
        tessellation of long slivers, see `SLIVER_LIMIT`).
    deflection, deflection_measured : float
        BRepMesh's linear deflection and the largest distance found between the
        tessellation and the surface (at the triangle centroids).
    sample_spacing : float
        3D step of the face sample grid (at most; from the largest |S_u|,
        |S_v| at the tessellation's nodes).
    n_face_samples, n_mesh_samples, n_tessellation_triangles : int
    error : str
        Why the file could not be measured ("" when it could).
    seconds : dict
    tessellation : TriMesh or None
        BRepMesh's triangles of the face read back (for pictures).
    """

    path: str
    readable: bool
    n_faces: int
    step_valid: bool
    area: float
    mesh_area: float
    area_ratio: float
    hausdorff: float
    hausdorff_mesh_to_face: float
    hausdorff_face_to_mesh: float
    rms_mesh_to_face: float
    where_mesh_to_face: np.ndarray
    where_face_to_mesh: np.ndarray
    boundary_deviation: float
    self_intersections: int
    deflection: float
    deflection_measured: float
    sample_spacing: float
    n_face_samples: int
    n_mesh_samples: int
    n_tessellation_triangles: int
    error: str = ""
    seconds: dict = field(default_factory=dict)
    tessellation: TriMesh | None = None

    def as_dict(self) -> dict:
        """JSON-ready figures (NaN -> None)."""
        def clean(v):
            if isinstance(v, np.ndarray):
                return [clean(x) for x in v.tolist()]
            if isinstance(v, float) and not math.isfinite(v):
                return None
            return v
        keys = ("readable", "n_faces", "step_valid", "area", "mesh_area", "area_ratio", "hausdorff",
                "hausdorff_mesh_to_face", "hausdorff_face_to_mesh", "rms_mesh_to_face", "where_mesh_to_face",
                "where_face_to_mesh", "boundary_deviation", "self_intersections", "deflection", "deflection_measured",
                "sample_spacing",
                "n_face_samples", "n_mesh_samples", "n_tessellation_triangles", "error")
        out = {k: clean(getattr(self, k)) for k in keys}
        out["seconds"] = {k: float(v) for k, v in self.seconds.items()}
        return out


def deflection_for(tolerance: float, diagonal: float) -> float:
    """BRepMesh deflection for measuring against `tolerance`: a tenth of it (at most 1e-3 of the diagonal).

    The mesh -> face distances are exact where the projection onto S lands
    inside the trims; the deflection bounds their error elsewhere and sets the
    resolution of the self-intersection count.
    """
    return float(min(0.1 * tolerance, 1e-3 * diagonal))


#: A face whose area exceeds the mesh's this many times is a runaway (an extrapolation gone wild): it is
#: tessellated on a (u, v) grid instead of by BRepMesh (which can take minutes on it) and its
#: self-intersections are not counted (-1); so is a face whose bounding box is this many times the mesh's.
RUNAWAY_AREA_RATIO = 10.0

#: Self-intersections are not counted (-1) when the mean of (triangle radius / median radius)^2 over the
#: tessellation exceeds this: long slivers across a wild face would make the pair search unbounded
#: (measured 1.3-2.2 on the fits that measure well, 28 on a wild cubic extrapolation of beetle_peyre).
SLIVER_LIMIT = 10.0

#: BRepMesh's angular deflection (radians): the linear deflection drives the tessellation of a smooth face;
#: 0.5 gave 84K triangles (3.4 s) on a folded fit of camelhead, 1.0 gives 46K, the same count on good fits.
ANGULAR_DEFLECTION = 1.0

#: Face samples aimed at when the tolerance would ask for more: the spacing grows to keep about this many.
MAX_FACE_SAMPLES = 20000


def _failed(path, mesh: TriMesh, error: str, *, readable=False, n_faces=0, valid=False, seconds=None) -> WrittenFace:
    nan = float("nan")
    return WrittenFace(str(path), readable, n_faces, valid, nan, mesh.area(), nan, nan, nan, nan, nan,
                       np.full(3, nan), np.full(3, nan), nan, -1, nan, nan, nan, 0, 0, 0, error, seconds or {})


def _read(path):
    """(shape, error) of a STEP file read with Open CASCADE, quietly."""
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.STEPControl import STEPControl_Reader

    from ..io._occ import quiet_occ

    shape, error = None, ""
    with quiet_occ():
        try:
            reader = STEPControl_Reader()
            status = reader.ReadFile(str(path))
            if status == IFSelect_RetDone:          # TransferRoots after a failed read crashes the process
                reader.TransferRoots()
                shape = reader.OneShape()
            else:
                error = f"Open CASCADE cannot read it (status {getattr(status, 'name', status)})"
        except Exception as exc:  # noqa: BLE001 - Open CASCADE's Standard_Failure
            error = f"Open CASCADE cannot read it ({type(exc).__name__}: {exc})"
    if shape is not None and shape.IsNull():
        shape, error = None, "Open CASCADE read an empty shape"
    return shape, error


def _faces(shape) -> list:
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    out, ex = [], TopExp_Explorer(shape, TopAbs_FACE)
    while ex.More():
        out.append(TopoDS.Face(ex.Current()))
        ex.Next()
    return out


def _triangulation(face):
    """(points (k, 3), uv (k, 2), triangles (m, 3)) of a meshed face, location applied."""
    from OCP.BRep import BRep_Tool
    from OCP.TopLoc import TopLoc_Location

    loc = TopLoc_Location()
    tri = BRep_Tool.Triangulation_s(face, loc)
    if tri is None or tri.NbTriangles() == 0 or not tri.HasUVNodes():
        return None
    trsf = loc.Transformation()
    nn, nt = tri.NbNodes(), tri.NbTriangles()
    pts = np.array([tri.Node(i).Transformed(trsf).Coord() for i in range(1, nn + 1)], dtype=np.float64)
    uv = np.array([tri.UVNode(i).Coord() for i in range(1, nn + 1)], dtype=np.float64)
    tris = np.array([tri.Triangle(i).Get() for i in range(1, nt + 1)], dtype=np.int64) - 1
    return pts, uv, tris


def _trim_polygons(face) -> list[np.ndarray]:
    """The face's trim loops in (u, v) as closed polygons: every wire's p-curves, sampled at their knots
    (exact for polylines) and at 32 points each."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepTools import BRepTools_WireExplorer
    from OCP.TopAbs import TopAbs_FORWARD, TopAbs_WIRE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    from ..io._occ import curve_from_occ

    fwd = TopoDS.Face(face.Oriented(TopAbs_FORWARD))
    out = []
    wires = TopExp_Explorer(fwd, TopAbs_WIRE)
    while wires.More():
        pieces = []
        ex = BRepTools_WireExplorer(TopoDS.Wire(wires.Current()), fwd)
        while ex.More():
            edge = ex.Current()
            pc = BRep_Tool.CurveOnSurface_s(edge, fwd, 0.0, 0.0)
            if pc is not None:
                a, b = BRep_Tool.Range_s(edge, fwd)
                c = curve_from_occ(pc, a, b, 2)
                k = c.knots[(c.knots > a) & (c.knots < b)]
                t = np.unique(np.r_[np.linspace(a, b, 33), k])
                p = c.evaluate(t)
                if edge.Orientation() != TopAbs_FORWARD:
                    p = p[::-1]
                pieces.append(p[:-1])
            ex.Next()
        if pieces:
            out.append(np.vstack(pieces))
        wires.Next()
    return out


def _in_tessellation(points: np.ndarray, uv: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Whether each (u, v) point lies in a triangle of the face's (u, v) tessellation: the region Open CASCADE
    takes as the face (for a face whose loops cross, the even-odd reading of the loops can differ from it)."""
    from ._grid import locate

    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    if not len(pts):
        return np.zeros(0, dtype=bool)
    return locate(uv, tris, pts, k=8)[0] >= 0


def _grid_tessellation(surface, polygons: list[np.ndarray], n: int = 96):
    """(points, uv, triangles) of an n x n (u, v) grid over the trims' box, triangles whose centroid lies inside
    the trims (a jagged border: for runaway faces only)."""
    from ..geom.predicates import points_in_polygons

    allp = np.vstack(polygons)
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    gu, gv = np.linspace(lo[0], hi[0], n + 1), np.linspace(lo[1], hi[1], n + 1)
    uu, vv = np.meshgrid(gu, gv, indexing="ij")
    uv = np.column_stack([uu.ravel(), vv.ravel()])
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    a = (i * (n + 1) + j).ravel()
    b, c, d = a + (n + 1), a + (n + 2), a + 1
    tris = np.concatenate([np.c_[a, b, c], np.c_[a, c, d]])
    tris = tris[points_in_polygons(uv[tris].mean(axis=1), polygons)]
    if not len(tris):
        return None
    used = np.unique(tris)
    remap = np.full(len(uv), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    uv = uv[used]
    return surface.evaluate(uv), uv, remap[tris]


def _grid_samples(uv: np.ndarray, tris: np.ndarray, surface, spacing: float, max_samples: int,
                  polygons) -> np.ndarray:
    """(u, v) of a grid inside the tessellated region whose 3D steps are at most about `spacing`.

    The (u, v) steps are `spacing` over the largest |S_u| and |S_v| at the
    tessellation's nodes (grown when the grid would exceed 2 `max_samples`
    points over the (u, v) box)."""
    d = surface.derivatives(uv, 1)
    su = float(np.max(np.linalg.norm(d[1, 0], axis=1)))
    sv = float(np.max(np.linalg.norm(d[0, 1], axis=1)))
    lo, hi = uv.min(axis=0), uv.max(axis=0)
    ext = np.maximum(hi - lo, 1e-300)
    h = np.array([spacing / max(su, 1e-300), spacing / max(sv, 1e-300)])
    n = np.ceil(ext / h)
    if n[0] * n[1] > 2 * max_samples:
        n = np.maximum(np.floor(n * np.sqrt(2 * max_samples / (n[0] * n[1]))), 1)
    gu = np.linspace(lo[0], hi[0], int(n[0]) + 1)
    gv = np.linspace(lo[1], hi[1], int(n[1]) + 1)
    uu, vv = np.meshgrid(gu, gv, indexing="ij")
    g = np.column_stack([uu.ravel(), vv.ravel()])
    return g[_in_tessellation(g, uv, tris)]


def _longest_edge(mesh: TriMesh) -> float:
    p = mesh.vertices[mesh.triangles]
    return float(np.max(np.linalg.norm(p - np.roll(p, -1, axis=1), axis=2)))


def _max_relevant_distances(points: np.ndarray, mesh: TriMesh) -> np.ndarray:
    """Distances of points to a mesh: exact where a point may hold the maximum, else to the nearest vertex.

    A point's distance to the mesh lies between its distance to the nearest
    vertex d_v and d_v - e (e: the longest edge), so only points with
    d_v >= max d_v - e can hold the maximum; they get the exact closest
    point. This keeps far-off samples (a face that leaves the mesh) from
    visiting every triangle.
    """
    from scipy.spatial import cKDTree

    from ..quality import closest_points_on_mesh

    d_v, _ = cKDTree(mesh.vertices).query(points)
    cand = d_v >= d_v.max() - _longest_edge(mesh)
    out = d_v.copy()
    out[cand] = closest_points_on_mesh(points[cand], mesh).distance
    return out


def _nearest_on_tessellation(points: np.ndarray, tess: TriMesh) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(distance, triangle, barycentric) of each point's nearest point on the tessellation: exact where it may
    hold the maximum (as in `_max_relevant_distances`), else the nearest node (one of its triangles)."""
    from scipy.spatial import cKDTree

    from ..quality import closest_points_on_mesh

    d_v, node = cKDTree(tess.vertices).query(points)
    t = tess.triangles
    # a triangle of each node and the node's corner in it
    owner = np.full(len(tess.vertices), -1, dtype=np.int64)
    corner = np.zeros(len(tess.vertices), dtype=np.int64)
    for c in range(3):
        owner[t[:, c]] = np.arange(len(t))
        corner[t[:, c]] = c
    tri = owner[node]
    bary = np.zeros((len(points), 3))
    bary[np.arange(len(points)), corner[node]] = 1.0
    cand = (d_v >= d_v.max() - _longest_edge(tess)) | (tri < 0)
    if cand.any():
        cp = closest_points_on_mesh(points[cand], tess)
        d_v[cand], tri[cand], bary[cand] = cp.distance, cp.triangle, cp.barycentric
    return d_v, tri, bary


def _segment_samples(a: np.ndarray, b: np.ndarray, step: float, max_per_segment: int = 64) -> np.ndarray:
    n = np.clip(np.ceil(np.linalg.norm(b - a, axis=1) / step), 1, max_per_segment).astype(np.int64)
    idx = np.repeat(np.arange(len(a)), n)
    t = (np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)) / np.repeat(n, n)
    return a[idx] + t[:, None] * (b[idx] - a[idx])


def _closest_on_segments(points: np.ndarray, a: np.ndarray, b: np.ndarray, k: int = 8
                         ) -> tuple[np.ndarray, np.ndarray]:
    """(distance, closest point) of each point on the segments [a_j, b_j] (exact over the k segments with the
    nearest midpoints), any dimension."""
    from scipy.spatial import cKDTree

    from ..quality import point_segment_closest

    k = int(min(k, len(a)))
    _, idx = cKDTree(0.5 * (a + b)).query(points, k=k)
    idx = np.asarray(idx).reshape(len(points), k)
    q = np.repeat(points, k, axis=0)
    c, _ = point_segment_closest(q, a[idx.ravel()], b[idx.ravel()])
    d = np.linalg.norm(c - q, axis=1).reshape(len(points), k)
    best = np.argmin(d, axis=1)
    return d[np.arange(len(points)), best], c.reshape(len(points), k, -1)[np.arange(len(points)), best]


def _distance_to_segments(points: np.ndarray, a: np.ndarray, b: np.ndarray, k: int = 8) -> np.ndarray:
    return _closest_on_segments(points, a, b, k)[0]


def _boundary_deviation(mesh: TriMesh, trims_3d: list[np.ndarray]) -> float:
    """Two-sided sampled distance between the mesh's border edges and the face's trim curves (closed polylines
    of points on them)."""
    em = mesh.boundary_edges()
    if not len(em) or not trims_3d:
        return float("nan")
    am, bm = mesh.vertices[em[:, 0]], mesh.vertices[em[:, 1]]
    at = np.vstack(trims_3d)
    bt = np.vstack([np.roll(p, -1, axis=0) for p in trims_3d])
    step = float(np.linalg.norm(bm - am, axis=1).mean()) / 4
    d1 = _distance_to_segments(_segment_samples(am, bm, step), at, bt)
    d2 = _distance_to_segments(at, am, bm)            # the trim points are already sampled at about `step`
    return float(max(d1.max(), d2.max()))


def _trims_3d(surface, polygons: list[np.ndarray], step: float, max_per_edge: int = 64) -> list[np.ndarray]:
    """The trim curves S(lambda) as closed 3D polylines: each (u, v) polygon edge cut into pieces whose 3D
    chords are at most about `step` (at most `max_per_edge` pieces)."""
    out = []
    for pg in polygons:
        a, b = pg, np.roll(pg, -1, axis=0)
        chord = np.linalg.norm(surface.evaluate(b) - surface.evaluate(a), axis=1)
        n = np.clip(np.ceil(chord / step), 1, max_per_edge).astype(np.int64)
        idx = np.repeat(np.arange(len(a)), n)
        t = (np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)) / np.repeat(n, n)
        out.append(surface.evaluate(a[idx] + t[:, None] * (b[idx] - a[idx])))
    return out


def measure_written_face(path, mesh: TriMesh, *, tolerance: float | None = None, sample_spacing: float | None = None,
                         self_intersections: bool = True) -> WrittenFace:
    """Read the STEP file `path` back through Open CASCADE and measure its face against `mesh`.

    Parameters
    ----------
    path : str or Path
        A STEP file written by `trimsurf.io.write_shell` (one face).
    mesh : TriMesh
        The mesh the face was fitted to.
    tolerance : float or None
        The deviation the caller will hold the face to (model units); sets the
        tessellation deflection (`deflection_for`). Default 1% of the mesh's
        diagonal.
    sample_spacing : float or None
        3D step of the face's (u, v) sample grid; default the tolerance, at
        least 1/300 of the diagonal and enough for about `MAX_FACE_SAMPLES`
        samples over the face's area, so the face samples number about
        area / spacing^2 whatever the mesh's size.
    self_intersections : bool
        Count intersecting pairs of the tessellation's triangles.

    Returns
    -------
    WrittenFace
        ``readable`` False (and NaN figures, ``error`` set) when Open CASCADE
        cannot read the file, it holds no face, or the face cannot be meshed.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from trimsurf.fit import fit_trimmed_face
    >>> from trimsurf.io import write_shell
    >>> from trimsurf.samples import holed_sheet
    >>> mesh = holed_sheet(max_area=600.0)
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "sheet.step"
    >>> write_shell(fit_trimmed_face(mesh, embed_method="lscm", grid_shape=(10, 8)).face, path)
    >>> w = measure_written_face(path, mesh)
    >>> w.step_valid, abs(w.area_ratio - 1) < 0.01, w.hausdorff < 0.005 * mesh.diagonal()
    (True, True, True)
    """
    from OCP.BRepCheck import BRepCheck_Analyzer
    from OCP.BRepGProp import BRepGProp
    from OCP.BRepMesh import BRepMesh_IncrementalMesh
    from OCP.BRepTools import BRepTools
    from OCP.BRep import BRep_Tool
    from OCP.GProp import GProp_GProps

    from ..geom.projection import project_to_surface
    from ..io._occ import quiet_occ, surface_from_occ
    from ..quality import closest_points_on_mesh
    from ..quality import self_intersections as self_int
    secs: dict = {}
    t = time.perf_counter()
    diag = mesh.diagonal()
    tol = 0.01 * diag if tolerance is None else float(tolerance)
    shape, error = _read(path) if Path(path).is_file() else (None, "no such file")
    secs["read"] = time.perf_counter() - t
    if shape is None:
        return _failed(path, mesh, error, seconds=secs)
    faces = _faces(shape)
    if not faces:
        return _failed(path, mesh, "the file holds no face", readable=True, seconds=secs)
    t = time.perf_counter()
    with quiet_occ():
        valid = bool(BRepCheck_Analyzer(shape).IsValid())
    secs["check"] = time.perf_counter() - t
    t = time.perf_counter()
    props = GProp_GProps()
    with quiet_occ():
        BRepGProp.SurfaceProperties_s(shape, props, 1e-6)
    area = float(props.Mass())
    secs["area"] = time.perf_counter() - t
    if sample_spacing is None:
        spacing = max(tol, math.sqrt(max(abs(area), 0.0) / (0.43 * MAX_FACE_SAMPLES)), diag / 300.0)
    else:
        spacing = float(sample_spacing)
    t = time.perf_counter()
    defl = max(deflection_for(tol, diag), 1e-3 * math.sqrt(max(abs(area), 0.0)))
    m_area = mesh.area()
    runaway = m_area > 0 and abs(area) > RUNAWAY_AREA_RATIO * m_area
    if not runaway:
        with quiet_occ():
            try:
                BRepMesh_IncrementalMesh(shape, defl, False, ANGULAR_DEFLECTION, False)
            except Exception as exc:  # noqa: BLE001
                return _failed(path, mesh, f"BRepMesh cannot mesh the face ({type(exc).__name__})", readable=True,
                               n_faces=len(faces), valid=valid, seconds=secs)
    # every face of the file, each with its own surface (a fit writes one)
    tess_pts, tess_tris, sample_tris = [], [], []
    n_tess = 0
    for f in faces:
        u0, u1, v0, v1 = BRepTools.UVBounds_s(f)
        with quiet_occ():
            surface = surface_from_occ(BRep_Tool.Surface_s(f), np.array([u0, v0]), np.array([u1, v1]))
        polygons = _trim_polygons(f)
        tri = _grid_tessellation(surface, polygons) if runaway else _triangulation(f)
        if tri is None:
            continue
        pts, uv, tris = tri
        tess_pts.append(pts)
        tess_tris.append(tris + sum(len(p) for p in tess_pts[:-1]))
        n_tess += len(tris)
        sample_tris.append((surface, _grid_samples(uv, tris, surface, spacing, MAX_FACE_SAMPLES, polygons), uv, tris,
                            pts, polygons))
    secs["tessellate"] = time.perf_counter() - t
    if not tess_pts:
        return _failed(path, mesh, "BRepMesh left the face without triangles", readable=True, n_faces=len(faces),
                       valid=valid, seconds=secs)
    t = time.perf_counter()
    tess = TriMesh(np.vstack(tess_pts), np.vstack(tess_tris))
    # face -> mesh: exact surface points at the tessellation's nodes, its triangles' centroids and a (u, v) grid
    fpts, defl_meas, spacing_meas = [], 0.0, 0.0
    for surface, guv, uv, tris, pts, polygons in sample_tris:
        cuv = uv[tris].mean(axis=1)
        tc = surface.evaluate(cuv)
        # samples off the nodes: in the tessellated region, and for a valid face inside its loops too (the chords
        # of a concave stretch of a trim leave the face)
        suv = np.vstack([cuv, guv])
        if valid:
            from ..geom.predicates import points_in_polygons
            suv = suv[points_in_polygons(suv, polygons)]
        fpts.extend([pts, surface.evaluate(suv)])
        # deflection of BRepMesh's own triangles, at their centroids
        defl_meas = max(defl_meas, float(np.max(np.linalg.norm(tc - pts[tris].mean(axis=1), axis=1))))
        p = pts[tris]
        longest = np.max(np.linalg.norm(p - np.roll(p, -1, axis=1), axis=2), axis=1)
        spacing_meas = max(spacing_meas, min(float(longest.max()), spacing))
    # and the trim curves S(lambda), sampled at a quarter of the mesh's mean border edge
    be = mesh.boundary_edges()
    mstep = float(np.linalg.norm(np.diff(mesh.vertices[be], axis=1), axis=2).mean()) / 4 if len(be) else spacing
    trims = [t3 for surface, _g, _uv, _t, _p, polygons in sample_tris for t3 in _trims_3d(surface, polygons, mstep)]
    fpts = np.vstack(fpts + trims)
    d_face = _max_relevant_distances(fpts, mesh)
    secs["face_to_mesh"] = time.perf_counter() - t
    t = time.perf_counter()
    # mesh -> face: each vertex to the tessellation (nearest node; exact closest point where it may be the
    # largest), refined by projection onto S from there
    mpts = mesh.vertices
    d_mesh, tri_of, bary_of = _nearest_on_tessellation(mpts, tess)
    offset = 0
    for surface, _guv, uv, tris, pts, polygons in sample_tris:
        sel = (tri_of >= offset) & (tri_of < offset + len(tris))
        if sel.any():
            local = tri_of[sel] - offset
            uv0 = np.einsum("kj,kjd->kd", bary_of[sel], uv[tris[local]])
            proj = project_to_surface(mpts[sel], surface.degree_u, surface.degree_v, surface.knots_u,
                                      surface.knots_v, surface.control_points, surface.weights, uv0=uv0,
                                      retry=False, max_iter=20)
            inside = _in_tessellation(proj.uv, uv, tris)
            if valid and not inside.all():
                # near the border the tessellation's chords cut the trims: there the loops decide (a valid
                # face's loops do not cross, so their even-odd reading is Open CASCADE's)
                from ..geom.predicates import points_in_polygons
                inside[~inside] = points_in_polygons(proj.uv[~inside], polygons)
            inside &= proj.converged
            d = np.where(inside, proj.distance, np.inf)
            if (~inside).any():
                # foot outside the trims (or on them): the nearest trim point q in (u, v); S(q) is a point of the
                # face, so |x - S(q)| bounds the distance from above (exact for a mesh border vertex on the trim)
                pa = np.vstack(polygons)
                pb = np.vstack([np.roll(pg, -1, axis=0) for pg in polygons])
                _, q = _closest_on_segments(proj.uv[~inside], pa, pb)
                d[~inside] = np.linalg.norm(surface.evaluate(q) - mpts[sel][~inside], axis=1)
            idx = np.flatnonzero(sel)
            d_mesh[idx] = np.minimum(d_mesh[idx], d)
        offset += len(tris)
    secs["mesh_to_face"] = time.perf_counter() - t
    t = time.perf_counter()
    # a face reaching far beyond the mesh is a runaway too: its long triangles would make every pair a candidate
    runaway = runaway or tess.diagonal() > RUNAWAY_AREA_RATIO * diag
    p = tess.vertices[tess.triangles]
    rad = np.linalg.norm(p - p.mean(axis=1, keepdims=True), axis=2).max(axis=1)
    slivers = float(np.mean((rad / max(float(np.median(rad)), 1e-300)) ** 2)) > SLIVER_LIMIT
    n_si = int(self_int(tess).n_pairs) if self_intersections and not runaway and not slivers else -1
    secs["self_intersections"] = time.perf_counter() - t
    t = time.perf_counter()
    bd = _boundary_deviation(mesh, trims)
    secs["boundary"] = time.perf_counter() - t
    km, kf = int(np.argmax(d_mesh)), int(np.argmax(d_face))
    h_mf, h_fm = float(d_mesh[km]), float(d_face[kf])
    return WrittenFace(str(path), True, len(faces), valid, area, m_area, area / m_area if m_area > 0 else float("nan"),
                       max(h_mf, h_fm), h_mf, h_fm, float(np.sqrt(np.mean(d_mesh ** 2))), mpts[km].copy(),
                       fpts[kf].copy(), bd, n_si, defl, defl_meas, spacing_meas, len(fpts), len(mpts), n_tess, "", secs,
                       tess)

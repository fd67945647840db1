"""Join the face meshes of a shell along every shared edge (Sec. III-B/C for all faces at once)."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError, MeshError
from ..model import Shell, TriMesh
from ._boundary import EdgePolyline, arc_length_fractions, delete_loops, edge_table, median_polyline, \
    sample_edge_curve
from ._chains import mesh_chains
from ._fallback import collapse_coincident
from ._patch import PAPER_BOUNDARY_ANGLE_DEG, PAPER_MIN_ANGLE_DEG, _angles_deg, cached_scale, MeshProjection, PatchResult, heights, join_patch, project_mesh, \
    project_near, project_points, repair_pole_turns, split_edges

__all__ = ["FaceReport", "JoinResult", "join_shell"]

_MAX_STEINER_ROUNDS = 4     # re-triangulations to share the points Triangle puts on dR with the neighbour
_DEFAULT_MAX_DISTANCE_REL = 1e-2   # a mesh vertex farther than this x diagonal from its face: bad mesh
_DEGENERATE_SEGMENTS = 8
_MAX_MIN_ANGLE_DEG = 33.8   # Triangle terminates in practice up to about this quality bound
_CHORD_REL = 2e-4          # default chord tolerance of the edge-curve polylines, x diagonal
_MIN_CLOSED_SEGMENTS = 6   # a closed edge (a loop of its own) gets at least this many segments
_COLLAPSE_REL = 1e-12       # input mesh edges at most this x diagonal long are one point (`collapse_coincident`)
_CROSSING_ROUNDS = 12      # rounds of splitting chords whose (u, v) images cross (`_split_crossing_chords`)
_FAKE_POLE_REL = 1e-7      # a collapsed edge along which F moves more than this x the control net: no pole
_FINAL_MERGE = 1e-9         # in the last pass only coinciding points are one point
_MERGE_FRACTION = 0.2       # Steiner points closer than this fraction of a boundary segment are one point


@dataclass
class FaceReport:
    """What the join did on one face."""

    face: int
    name: str
    status: str = "joined"           # "joined", "remeshed" (whole domain re-triangulated), "bad" (not moved), "empty"
    message: str = ""                # for "bad" and "remeshed": why
    n_collapsed: int = 0             # input mesh vertices merged into a coinciding neighbour (`collapse_coincident`)
    max_distance: float = 0.0        # largest vertex distance to the surface found (step 1)
    n_turned: int = 0                # triangles turned over in (u, v) (M^-1 not injective)
    lipschitz: float = float("nan")
    eps_max: float = float("nan")
    min_angle_external_deg: float = float("nan")
    min_input_angle_deg: float = float("nan")
    n_central: int = 0
    n_removed: int = 0
    n_split_long: int = 0
    flipped_before: int = 0
    flipped_after: int = 0
    whitney_blocks: float = 0.0
    boundary_steiner_allowed: bool = True   # False: last pass without points on dR (no angle guarantee)
    refine_passes: int = 0           # Triangle size-refinement passes until the strip met the deflection
    pole_flips: int = 0              # edges flipped beside a pole where a triangle turned over in 3D

    def as_dict(self) -> dict:
        return {k: (float(v) if isinstance(v, (float, np.floating)) else v) for k, v in self.__dict__.items()}


@dataclass
class JoinResult:
    """The joined mesh (one `TriMesh` with ``face_id``), per-face data and a report dict.

    ``patches[i]`` is the `PatchResult` of face i (None for a bad or empty
    face); ``vertex_of[i]`` maps its vertices to ``mesh`` vertices.
    """

    mesh: TriMesh
    faces: list[FaceReport]
    patches: list
    vertex_of: list
    edges: list[EdgePolyline]
    report: dict = field(default_factory=dict)

    @property
    def bad_faces(self) -> list[int]:
        return [f.face for f in self.faces if f.status == "bad"]

    @property
    def remeshed_faces(self) -> list[int]:
        """Faces whose input mesh could not be inverted: re-triangulated over their whole (u, v) domain."""
        return [f.face for f in self.faces if f.status == "remeshed"]

    def __bool__(self) -> bool:
        return not self.bad_faces

    def to_table(self) -> list[dict]:
        """The report as a one-row table (a list with one flat dict) that ``pandas.DataFrame`` accepts."""
        from ..viz._notebook import report_table  # viz is a higher layer: imported on use only
        return report_table(self)

    def _repr_html_(self) -> str:
        """Jupyter: the interactive viewer inline (offline) and the report's key figures."""
        from ..viz._notebook import repr_html
        return repr_html(self)


# boundary slopes (dimensionless heights per unit of (u, v) distance) at or below this are rounding
SLOPE_ROUNDING = 1e-9


def _check_inputs(shell: Shell, meshes: Sequence[TriMesh]) -> None:
    if not isinstance(shell, Shell):
        raise InputError(f"join_shell: expected a Shell; got {type(shell).__name__}")
    if len(meshes) != len(shell.faces):
        raise InputError(f"join_shell: need one mesh per face: the shell has {len(shell.faces)} faces, "
                         f"got {len(meshes)} meshes")
    for i, m in enumerate(meshes):
        if not isinstance(m, TriMesh):
            raise InputError(f"join_shell: mesh {i} is a {type(m).__name__}, not a TriMesh")


def _with_domain_loops(shell: Shell) -> Shell:
    """The shell with every untrimmed face (no loops: the whole domain) bounded by its domain rectangle."""
    from dataclasses import replace

    from ..model import Loop, NurbsCurve, PCurve

    if all(f.loops for f in shell.faces):
        return shell
    faces = []
    for f in shell.faces:
        if f.loops:
            faces.append(f)
            continue
        (u0, u1), (v0, v1) = f.surface.domain
        c = [(u0, v0), (u1, v0), (u1, v1), (u0, v1)]
        segs = tuple(PCurve(NurbsCurve(1, [0.0, 0.0, 1.0, 1.0], np.array([c[k], c[(k + 1) % 4]], dtype=float)),
                            0.0, 1.0) for k in range(4))
        faces.append(replace(f, loops=(Loop(segs),)))
    return Shell(tuple(faces), shell.edges, shell.vertices, name=shell.name)


def _flipped(face, uv: np.ndarray, vertices: np.ndarray, tris: np.ndarray) -> int:
    """Triangles whose normal points against the face's outward normal at their (u, v) centroid."""
    if not len(tris):
        return 0
    p = vertices[tris]
    nt = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    ns = face.oriented_normals(uv[tris].mean(axis=1))
    dot = np.einsum("ij,ij->i", nt, ns)
    return int(np.count_nonzero(dot < 0))


def _sample_edges(shell: Shell, edges: list[EdgePolyline], meshes, projs, chains, spacing, use_edge_curves: bool,
                  chord_tol: float):
    """Build every edge's polyline: Case 1 from b(t), Case 2 from the mesh boundaries (median where joined)."""
    n_loops_deleted = 0
    for ed in edges:
        ends = [shell.vertices[v] if v >= 0 else None for v in ed.vertices]
        faces = sorted(ed.faces)
        h = min(spacing[f] for f in faces) if faces else 0.0
        if ed.degenerate:
            p = ends[0] if ends[0] is not None else (ends[1] if ends[1] is not None else None)
            if p is None:
                f, li, si, _ = ed.uses[0]
                seg = shell.faces[f].loops[li].segments[si]
                p = shell.faces[f].surface.evaluate(seg.curve.evaluate([seg.t0]))[0]
            ed.points = np.repeat(np.asarray(p, float)[None], _DEGENERATE_SEGMENTS + 1, axis=0)
            ed.tpar = np.linspace(ed.t0, ed.t1, _DEGENERATE_SEGMENTS + 1)
            continue
        chain_pts = []
        for f, li, si, fwd in ed.uses:
            c = chains[f].get((li, si))
            if c is None or projs[f] is None:
                continue
            pts = meshes[f].vertices[c]
            chain_pts.append(pts if fwd else pts[::-1])
        if ed.curve is not None and (use_edge_curves or not chain_pts):
            ends_t = ed.curve.evaluate([ed.t0, ed.t1])
            closed = np.linalg.norm(ends_t[1] - ends_t[0]) <= 1e-9 * max(np.ptp(ed.curve.control_points), 1e-300)
            pts, t = sample_edge_curve(ed.curve, ed.t0, ed.t1, h if h > 0 else np.inf,
                                       min_segments=_MIN_CLOSED_SEGMENTS if closed else 2,
                                       chord_tolerance=chord_tol)
            ed.case = 1
        elif chain_pts:
            if len(chain_pts) >= 2:
                pts, s = median_polyline(chain_pts[0], chain_pts[1])
            else:
                pts = chain_pts[0]
                s = arc_length_fractions(pts)
            t = ed.t0 + s * (ed.t1 - ed.t0)
            ed.case = 2
        else:
            # neither a curve nor a mesh chain: the straight segment between the ends (or the p-curve image)
            f, li, si, fwd = ed.uses[0]
            seg = shell.faces[f].loops[li].segments[si]
            t = np.linspace(ed.t0, ed.t1, 9)
            pts = shell.faces[f].surface.evaluate(seg.curve.evaluate(t if fwd else t[::-1]))
            pts = pts if fwd else pts[::-1]
            ed.case = 2
        pts = np.array(pts, dtype=np.float64)
        if ends[0] is not None:
            pts[0] = ends[0]
        if ends[1] is not None:
            pts[-1] = ends[1]
        if ed.case == 2 and len(ed.uses) >= 1:
            # Case 2: delete loops of the (u, v) image on the first face
            f, li, si, fwd = ed.uses[0]
            seg = shell.faces[f].loops[li].segments[si]
            uv0 = seg.curve.evaluate(t if fwd else t[::-1])
            w = project_points(shell.faces[f], pts if fwd else pts[::-1], uv0=uv0).uv
            w = w if fwd else w[::-1]
            pts, _, t, cut = delete_loops(pts, w, t)
            n_loops_deleted += cut
        ok = np.r_[True, np.linalg.norm(np.diff(pts, axis=0), axis=1) > 0]
        ok[-1] = True
        if len(pts) > 2 and np.linalg.norm(pts[-1] - pts[-2]) == 0:
            ok[-2] = False
        ed.points, ed.tpar = pts[ok], np.asarray(t, dtype=np.float64)[ok]
    return n_loops_deleted


class _Ids:
    """Stable global ids of boundary points: shell vertices first, then points as they are created."""

    def __init__(self, shell: Shell):
        self.pos = {i: p for i, p in enumerate(shell.vertices)}
        self.next = len(shell.vertices)

    def new(self, points: np.ndarray) -> np.ndarray:
        ids = self.next + np.arange(len(points))
        self.next += len(points)
        for i, p in zip(ids.tolist(), points):
            self.pos[i] = p
        return ids

    def positions(self) -> np.ndarray:
        out = np.zeros((self.next, 3))
        for i, p in self.pos.items():
            out[i] = p
        return out


def _assign_ids(edges: list[EdgePolyline], ids: _Ids) -> None:
    """Ids of every edge polyline point (ends: the shell vertices; a closed edge without vertices: one id)."""
    for ed in edges:
        k = len(ed.points)
        g = np.empty(k, dtype=np.int64)
        v0, v1 = ed.vertices
        g[0] = v0 if v0 >= 0 else ids.new(ed.points[:1])[0]
        if v1 >= 0:
            g[-1] = v1
        elif v0 < 0 and np.linalg.norm(ed.points[-1] - ed.points[0]) == 0:
            g[-1] = g[0]
        else:
            g[-1] = ids.new(ed.points[-1:])[0]
        if ed.degenerate:
            g[:] = g[0]
        elif k > 2:
            g[1:-1] = ids.new(ed.points[1:-1])
        ed.gid = g


def _face_loops(shell: Shell, f: int, edges, use_key):
    """dR of face f: per loop the points, tpar-based warm starts, ids and (edge, canonical index, forward)."""
    face = shell.faces[f]
    loops = []
    for li, loop in enumerate(face.loops):
        xyz, uv0, gid, ref, pole = [], [], [], [], []
        for si, seg in enumerate(loop.segments):
            ed = edges[use_key[(f, li, si)]]
            fwd = next(u[3] for u in ed.uses if u[:3] == (f, li, si))
            k = len(ed.points)
            idx = np.arange(k) if fwd else np.arange(k)[::-1]
            idx = idx[:-1]  # the last point is the next piece's first
            xyz.append(ed.points[idx])
            uv0.append(seg.curve.evaluate(ed.tpar[idx]))
            gid.append(ed.gid[idx])
            ref.append(np.column_stack([np.full(len(idx), ed.key), idx, np.full(len(idx), int(fwd))]))
            pole.append(np.full(len(idx), ed.degenerate))
        loops.append((np.concatenate(xyz), np.concatenate(uv0), np.concatenate(gid), np.concatenate(ref),
                      np.concatenate(pole)))
    return loops


def _project_loops(face, loops):
    """Step 2: project the boundary points to (u, v); eps their heights (0 at poles, uv from the p-curve)."""
    out = []
    for xyz, uv0, gid, ref, pole in loops:
        uv = uv0.copy()
        if (~pole).any():
            seg = np.linalg.norm(np.diff(xyz, axis=0), axis=1)
            spacing = float(np.median(seg[seg > 0])) if np.any(seg > 0) else 0.0
            pr = project_near(face, xyz[~pole], uv0[~pole], spacing=spacing)
            uv[~pole] = pr.uv
        if pole.any():
            keep_pts, at_pole = _short_edge_runs(face, uv, xyz, gid, pole, uv0)
            uv[at_pole] = uv0[at_pole]
            uv, xyz, gid, ref, pole = uv[keep_pts], xyz[keep_pts], gid[keep_pts], ref[keep_pts], pole[keep_pts]
        eps, _, _ = heights(face, uv, xyz)
        eps[pole] = 0.0
        # drop points that coincide in (u, v) with their predecessor (repeated ends)
        keep = np.ones(len(uv), dtype=bool)
        d = np.linalg.norm(np.diff(np.r_[uv, uv[:1]], axis=0), axis=1)
        keep[1:] &= d[:-1] > 0
        if d[-1] == 0 and len(uv) > 1:
            keep[-1] = False
        out.append((uv[keep], xyz[keep], eps[keep], gid[keep], ref[keep]))
    return out


def _short_edge_runs(face, uv: np.ndarray, xyz: np.ndarray, gid: np.ndarray, pole: np.ndarray,
                     uv0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Which dR points to keep: one point of each run of a collapsed edge that is no pole of the surface;
    and which points at a true pole take their p-curve's (u, v) instead of their projection.

    A model edge shorter than the sewing or reading tolerance comes with both ends at one vertex (U_Joint's
    5e-6 edges, the sewn bearing's 1.7e-6 edge): the join treats it as collapsed and puts all its points at
    that vertex, but its p-curve spans a piece of the (u, v) domain where the surface is regular (F varies
    along it), so dR would run there and back and cross itself, or hold triangles of no size in 3D that
    turn over. Where F along the run's (u, v) moves more than rounding (1e-7 of the control net's size:
    at a true pole it does not move), the run becomes one point: the vertex's own projection (a point of
    the run that is not on the collapsed edge), else the run's first point.

    At a true pole every (u, v) of the pole line is a closest point of the vertex: its projection as the end
    of the next edge may land at the other end of the pole line (the crankshaft's face 106: dR then runs
    back along the pole and crosses itself). Where the projection is farther than 1e-3 of the domain from
    the p-curve's (u, v), the p-curve's is taken.
    """
    k = len(gid)
    keep = np.ones(k, dtype=bool)
    at_pole = np.zeros(k, dtype=bool)
    if k < 3:
        return keep, at_pole
    start = np.flatnonzero(gid != np.roll(gid, 1))
    if not len(start):
        return keep, at_pole
    (u0, u1), (v0, v1) = face.surface.domain
    span = max(u1 - u0, v1 - v0)
    lo, hi = face.surface.control_bbox()
    tol = _FAKE_POLE_REL * float(np.linalg.norm(hi - lo))
    ends = np.r_[start[1:], start[0] + k]
    for s0, s1 in zip(start.tolist(), ends.tolist()):
        run = np.arange(s0, s1) % k
        if len(run) < 2 or not pole[run].any() or gid[run[0]] < 0:
            continue
        spread = np.linalg.norm(face.surface.evaluate(uv[run]) - xyz[run[0]], axis=1).max()
        if not spread > tol:
            own = run[~pole[run]]
            at_pole[own[np.linalg.norm(uv[own] - uv0[own], axis=1) > 1e-3 * span]] = True
            continue
        own = run[~pole[run]]
        kept = own[0] if len(own) else run[0]
        keep[run] = False
        keep[kept] = True
    return keep, at_pole


def join_shell(shell: Shell, meshes: Sequence[TriMesh], *, use_edge_curves: bool = True,
               min_angle_deg: float = PAPER_MIN_ANGLE_DEG, split_long_edges: bool = False,
               max_distance: float | None = None, edge_spacing: float | None = None,
               chord_tolerance: float | None = None, measure: bool = True, deflection: float | None = None,
               progress: Callable[[int, int], None] | None = None) -> JoinResult:
    """Join separately meshed faces of a shell into one mesh whose patch boundaries coincide.

    Parameters
    ----------
    shell : Shell
        The model; its edges say which faces adjoin (a shell without edges
        joins nothing: every face keeps its own boundary curves).
    meshes : sequence of TriMesh
        One mesh per face (``meshes[i]`` approximates ``shell.faces[i]``),
        in model units; ``uv`` is used as a warm start for the projection.
    use_edge_curves : bool
        Case 1 (True): b_k(t) are the shell's 3D edge curves. Case 2 (False,
        or edges without a curve): the mesh boundaries, their median where
        two faces meet (loops deleted).
    min_angle_deg : float
        Minimum angle Triangle's refinement enforces in the external region
        (default the paper's 21.96 deg, Sec. III-B).
    split_long_edges : bool
        Sec. III-D: split the longest (u, v) edge of every triangle thinner
        than `min_angle_deg` and reproject at the new vertex.
    max_distance : float, optional
        A mesh vertex farther from its face's surface is bad input for that
        face (default 1 % of the shell's diagonal).
    edge_spacing : float, optional
        Case 1: sample the edge curves about this far apart (model units);
        default the median boundary edge length of the adjoining meshes.
    chord_tolerance : float, optional
        Case 1: the edge-curve polylines are refined until each chord is
        within this of b(t) (default 2e-4 of the diagonal); points inserted
        later (Triangle's, shared with the neighbour) are put on b(t) itself.
    measure : bool
        Measure the report's after-figures by projecting the output vertices
        (costs about one more projection of the meshes) and the output's
        deviation inside the triangles (``max_deviation``, ``p99_deviation``:
        dense barycentric samples projected onto the faces).
    deflection : float, optional
        The largest deviation from the surface allowed inside the triangles
        the join adds (model units): Triangle refines the external region
        until each triangle's sampled deviation is within it (`_refine_to_deviation`).
        Default: the input meshes' own largest deviation, measured (so the
        join keeps the input's accuracy); ``inf``: no size bound (the paper's
        step 4 as written).
    progress : callable(done, total), optional

    Returns
    -------
    JoinResult
        ``mesh`` (with ``face_id``), per-face reports, ``report`` with the
        issue's fields. A face mesh with triangles that have two corners at
        one point is cleaned first (`_fallback.collapse_coincident`: the
        surface is unchanged). A face whose projection still turns triangles
        over (M^-1 not injective, Sec. II), or whose mesh crosses dR in
        (u, v), is re-triangulated over its whole domain (``status ==
        "remeshed"``, ``report["remeshed_faces"]``: step 4 with an empty
        central mesh, refined to the deflection). Faces whose mesh does not
        lie near the face, or whose dR still crosses itself (the trim curves
        cross), are ``status == "bad"``: their mesh is kept unchanged and
        unjoined, and the result is falsy.

    Raises
    ------
    InputError
        Not a shell, or not one TriMesh per face.

    References
    ----------
    join-mesh-patches-whitney.txt, Sec. III-B (Case 1, six steps), III-C
    (Case 2), III-D (long-edge splitting).

    Examples
    --------
    >>> from trimsurf.samples.folding_pair import folding_pair, folding_pair_meshes
    >>> shell = folding_pair()
    >>> res = join_shell(shell, folding_pair_meshes(shell))
    >>> res.report["flipped_after"], res.report["boundary_edges_on_joins"], bool(res)
    (0, 0, True)
    """
    t_start = time.perf_counter()
    _check_inputs(shell, meshes)
    shell = _with_domain_loops(shell)
    if not (np.isfinite(min_angle_deg) and 0.0 < min_angle_deg <= _MAX_MIN_ANGLE_DEG):
        raise InputError(f"join_shell: min_angle_deg must be in (0, {_MAX_MIN_ANGLE_DEG}] (Ruppert refinement "
                         f"need not terminate above); got {min_angle_deg!r}")
    diag = shell.diagonal()
    max_d = _DEFAULT_MAX_DISTANCE_REL * diag if max_distance is None else float(max_distance)
    nf = len(shell.faces)
    given = list(meshes)       # a face left unjoined keeps its mesh as given
    meshes = list(meshes)      # a face's mesh may be cleaned (`collapse_coincident`)
    collapse_tol = _COLLAPSE_REL * diag
    remesh: set[int] = set()   # faces re-triangulated over their whole domain (empty central mesh)
    reports = [FaceReport(i, shell.faces[i].name) for i in range(nf)]
    projs: list[MeshProjection | None] = [None] * nf
    chains: list[dict] = [{} for _ in range(nf)]
    spacing = np.zeros(nf)
    for i, (face, mesh) in enumerate(zip(shell.faces, meshes)):
        rep = reports[i]
        if mesh.n_triangles == 0:
            rep.status, rep.message = "empty", "mesh has no triangles"
            continue
        pr = project_mesh(face, mesh)
        rep.max_distance, rep.n_turned = pr.max_distance, pr.n_turned
        if measure:
            rep.flipped_before = _flipped(face, pr.uv, mesh.vertices, pr.triangles if face.same_sense
                                          else pr.triangles[:, ::-1])
        if pr.max_distance > max_d:
            rep.status = "bad"
            rep.message = (f"mesh does not lie near the face: a vertex is {pr.max_distance:.6g} from the surface "
                           f"(limit {max_d:.6g})")
            continue
        if pr.n_turned:
            # triangles with two corners at one point have no orientation in 3D: merge such corners (the
            # mesh's surface is unchanged) and project again
            cleaned, k = collapse_coincident(mesh, collapse_tol)
            if k:
                pr2 = project_mesh(face, cleaned)
                if pr2.max_distance <= max_d:
                    meshes[i], mesh, pr, rep.n_collapsed = cleaned, cleaned, pr2, k
        if pr.n_turned:
            # M^-1 not injective (Sec. II): the face is re-triangulated over its whole (u, v) domain
            rep.status = "remeshed"
            rep.message = (f"inverse map not injective: {pr.n_turned} triangles turn over when projected to "
                           f"(u, v); largest vertex distance {pr.max_distance:.6g}")
            remesh.add(i)
        else:
            rep.status = "joined"
        projs[i] = pr
        try:
            chains[i] = mesh_chains(face, pr.uv, pr.triangles)
        except Exception:   # noqa: BLE001 - a mesh that turns over may have no clean boundary walk
            if i not in remesh:
                raise
            chains[i] = {}
        be = [c for c in chains[i].values()]
        if be:
            seg = np.concatenate([np.linalg.norm(np.diff(mesh.vertices[c], axis=0), axis=1) for c in be])
            spacing[i] = float(np.median(seg[seg > 0])) if np.any(seg > 0) else 0.0
        if spacing[i] == 0:
            e = mesh.edges()
            spacing[i] = float(np.median(np.linalg.norm(mesh.vertices[e[:, 0]] - mesh.vertices[e[:, 1]], axis=1)))
    edges, use_key = edge_table(shell)
    if edge_spacing is not None:
        if not (np.isfinite(edge_spacing) and edge_spacing > 0):
            raise InputError(f"join_shell: edge_spacing must be a positive number; got {edge_spacing!r}")
        spacing[:] = float(edge_spacing)
    if deflection is None:
        from ._accuracy import input_deviation
        good = [i for i in range(nf) if projs[i] is not None]
        deflection = input_deviation(shell, meshes, faces=good) if good else float("inf")
    elif not (deflection > 0):
        raise InputError(f"join_shell: deflection must be a positive number; got {deflection!r}")
    t_proj = time.perf_counter() - t_start
    chord_tol = _CHORD_REL * diag if chord_tolerance is None else float(chord_tolerance)
    n_loops_deleted = _sample_edges(shell, edges, meshes, projs, chains, spacing, use_edge_curves, chord_tol)
    ids = _Ids(shell)
    _assign_ids(edges, ids)
    active = [i for i in range(nf) if projs[i] is not None]
    pre_loops: dict[int, list] = {}   # dR of the faces as the crossing check projected it (reused in round 1)
    n_split_crossing, crossed = _split_crossing_chords(shell, edges, use_key, active, ids, pre_loops)
    results: list[PatchResult | None] = [None] * nf
    todo = set(active)
    rounds = 0
    face_loops: dict[int, list] = {}
    caches: dict[int, dict] = {}
    n_final_points = 0
    while todo:
        rounds += 1
        final = rounds >= _MAX_STEINER_ROUNDS
        inserts: dict[int, list[tuple[int, float, int, int]]] = {}
        for i in sorted(todo):
            face = shell.faces[i]
            loops = pre_loops.pop(i, None) if rounds == 1 else None
            if loops is None:
                loops = _project_loops(face, _face_loops(shell, i, edges, use_key))
            face_loops[i] = loops
            # Sec. III-B's hypothesis: dR's corners >= 26.45 deg. Where it fails, Ruppert refinement splits the
            # dR segments near the sharp corner again at every pass (the neighbour's points move them a little):
            # such a face keeps its dR as given (Triangle's -Y) and claims no angle bound
            corner = _min_corner_angle([lp[0] for lp in loops],
                                       cached_scale(face, projs[i], caches.setdefault(i, {})))
            res = None
            for whole in ((False, True) if i not in remesh else (True,)):
                if whole:
                    central_init = np.zeros(len(projs[i].triangles), dtype=bool)   # no central mesh
                else:
                    central_init = None if results[i] is None else results[i].central_keep
                try:
                    res = join_patch(face, projs[i], meshes[i], [lp[0] for lp in loops], [lp[1] for lp in loops],
                                     [lp[2] for lp in loops], [lp[3] for lp in loops], min_angle_deg=min_angle_deg,
                                     split_long_edges=split_long_edges,
                                     allow_boundary_steiner=corner >= PAPER_BOUNDARY_ANGLE_DEG,
                                     central_init=central_init,
                                     cache=caches.setdefault(i, {}), max_deviation=deflection)
                    break
                except InputError as exc:
                    if whole:
                        reports[i].status, reports[i].message = "bad", str(exc)
                    else:
                        # the central mesh crosses dR: re-mesh the whole domain
                        reports[i].message = f"the input mesh crosses the boundary in (u, v): {exc}"
            if res is None:
                results[i] = None
                remesh.discard(i)
                continue
            if i not in remesh and reports[i].message:
                remesh.add(i)
                reports[i].status = "remeshed"
            results[i] = res
            for li, si, frac, vertex in res.boundary_steiner:
                key, cidx, fwd = (int(x) for x in loops[li][4][si])
                if fwd:
                    inserts.setdefault(key, []).append((cidx, frac, i, vertex))
                else:
                    inserts.setdefault(key, []).append((cidx - 1, 1.0 - frac, i, vertex))
            if progress is not None:
                progress(len(active) - len(todo) + 1, len(active))
        todo = set()
        if not inserts:
            break
        if final:
            # the points Triangle put on dR in this last pass go into the neighbours by splitting their
            # boundary triangles (Sec. III-B, step 6), then every touched face is reprojected exactly
            n_final_points = _finalize_steiner(shell, edges, use_key, results, inserts, ids, face_loops)
            break
        for key, items in inserts.items():
            ed = edges[key]
            ed.points, ed.tpar, ed.gid, _ = _insert_points(ed, [(j, f) for j, f, _, _ in items], ids,
                                                           merge=_MERGE_FRACTION)
            todo |= {u[0] for u in ed.uses if results[u[0]] is not None}
    n_chords = _split_conflicting_chords(shell, results)
    # beside a pole the parametrization is singular (outside Sec. II's hypothesis): edges of the external
    # region are flipped where a triangle turns over in 3D (`repair_pole_turns`)
    pole_faces = {u[0] for e in edges if e.degenerate for u in e.uses}
    # so where dR's chords crossed (cusps of the trim: thin slivers of the domain) or the face was re-meshed
    pole_faces |= crossed | remesh
    for i in sorted(pole_faces):
        if results[i] is not None:
            results[i], _ = repair_pole_turns(shell.faces[i], results[i])
    gpos = ids.positions()
    mesh_out, vertex_of = _merge(shell, given, results, reports, gpos)
    res = JoinResult(mesh_out, reports, results, vertex_of, edges)
    for i, r in enumerate(results):
        if r is None:
            continue
        rep = reports[i]
        rep.lipschitz, rep.eps_max = r.lipschitz, r.eps_max
        ang = _angles_deg((r.uv * r.scale)[r.triangles[r.external]])   # measured on the final patch
        rep.min_angle_external_deg = float(ang.min(initial=180.0))
        rep.min_input_angle_deg = r.min_input_angle_deg
        rep.n_central, rep.n_removed, rep.n_split_long = r.n_central, r.n_removed, r.n_split_long
        rep.whitney_blocks = r.whitney_blocks
        rep.boundary_steiner_allowed = r.boundary_steiner_allowed
        rep.pole_flips = int(r.pole_flips)
        rep.refine_passes = int(r.seconds.get("refine_passes", 0))
        face = shell.faces[i]
        if measure:
            tr = r.triangles if face.same_sense else r.triangles[:, ::-1]
            rep.flipped_after = _flipped(face, r.uv, r.points, tr)
    t_join = time.perf_counter() - t_start
    res.report = _summary(shell, res, measure)
    res.report["deflection"] = float(deflection)
    if measure:
        from ._accuracy import mesh_deviation_inside
        inside = mesh_deviation_inside(res.mesh, shell, uv_of=joined_uv(res))
        res.report.update({k: inside[k] for k in ("max_deviation", "p99_deviation", "worst_face",
                                                  "deviation_samples_per_edge")})
    steps = {k: float(sum(r.seconds[k] for r in results if r is not None)) for k in ("central", "triangulate",
                                                                                     "whitney", "refine")}
    res.report.update({"seconds_project": t_proj, "seconds_steps": steps, "seconds_join": t_join,
                       "boundary_segments_max": int(max((len(r.boundary.length) for r in results if r is not None),
                                                        default=0)),"steiner_rounds": rounds, "steiner_points_shared_by_split": n_final_points, "loops_deleted": n_loops_deleted,
                       "crossing_chords_split": n_split_crossing, "chords_split": n_chords,
                       "case": sorted({e.case for e in edges if e.joined}),
                       "seconds": time.perf_counter() - t_start})
    return res


def joined_uv(res: JoinResult) -> list:
    """Per face, the (u, v) of every output vertex the face's patch uses (NaN elsewhere): warm starts."""
    out = []
    for r, vo in zip(res.patches, res.vertex_of):
        if r is None or vo is None:
            out.append(None)
            continue
        uv = np.full((res.mesh.n_vertices, 2), np.nan)
        uv[vo] = r.uv
        out.append(uv)
    return out


def _summary(shell: Shell, res: JoinResult, measure: bool = True) -> dict:
    """The issue's report fields, measured on the result (heights by projecting the output vertices)."""
    from ._metrics import corner_slopes

    joined = [e for e in res.edges if e.joined]
    joint_ids = np.unique(np.concatenate([e.gid for e in joined])) if joined else np.zeros(0, dtype=np.int64)
    on_joint = np.zeros(res.mesh.n_vertices, dtype=bool)
    abs_after, slope_after, slope_ratio = 0.0, 0.0, float("nan")   # nan: no face with L above rounding
    for i, r in enumerate(res.patches):
        if r is None:
            continue
        sel = np.isin(r.gid, joint_ids)
        on_joint[res.vertex_of[i][sel]] = True
        if not measure:
            abs_after = slope_after = slope_ratio = float("nan")
            continue
        pr = project_points(shell.faces[i], r.points, uv0=r.uv)
        eta, _, _ = heights(shell.faces[i], pr.uv, r.points)
        abs_after = max(abs_after, float(np.abs(eta).max()))
        sl = corner_slopes(pr.uv, eta, r.triangles, r.scale)
        slope_after = max(slope_after, float(sl.max()))
        if r.lipschitz > SLOPE_ROUNDING:   # a ratio to L at rounding level (L ~ 1e-14) says nothing
            slope_ratio = np.nanmax([slope_ratio, float(sl.max()) / r.lipschitz])
    ok = [f for f in res.faces if f.status in ("joined", "remeshed")]
    # boundary edges between two joint vertices: only triangles with two joint corners can have one
    t = res.mesh.triangles
    cand = t[on_joint[t].sum(axis=1) >= 2]
    he = np.stack([cand, np.roll(cand, -1, axis=1)], axis=2).reshape(-1, 2)
    he = he[on_joint[he].all(axis=1)]
    key = np.minimum(he[:, 0], he[:, 1]) * max(res.mesh.n_vertices, 1) + np.maximum(he[:, 0], he[:, 1])
    _, cnt = np.unique(key, return_counts=True)
    n_on_joins = int(np.count_nonzero(cnt == 1))
    # a joint edge also used by a bad face's own (unjoined) mesh cannot occur: bad meshes keep own vertices
    def fmax(vals):
        vals = [v for v in vals if np.isfinite(v)]
        return float(max(vals)) if vals else None

    def fmin(vals):
        vals = [v for v in vals if np.isfinite(v)]
        return float(min(vals)) if vals else None

    return {
        "vertices": res.mesh.n_vertices,
        "triangles": res.mesh.n_triangles,
        "joined_edges": len(joined),
        "flipped_before": int(sum(f.flipped_before for f in res.faces)),
        "flipped_after": int(sum(f.flipped_after for f in ok)),
        "abs_error_boundary": fmax([f.eps_max for f in ok]),
        "abs_error_after": abs_after,
        "lipschitz_boundary": fmax([f.lipschitz for f in ok]),
        "max_slope_after": slope_after,
        "max_slope_over_lipschitz": slope_ratio,
        "min_angle_external_deg": fmin([f.min_angle_external_deg for f in ok]),
        "min_boundary_angle_deg": fmin([f.min_input_angle_deg for f in ok]),
        "faces_angle_bound_claimed": int(sum(1 for f in ok if f.boundary_steiner_allowed and not f.pole_flips
                                             and f.min_input_angle_deg >= 26.45)),
        "faces_angle_bound_not_claimed": [f.face for f in ok if not (f.boundary_steiner_allowed
                                                                     and not f.pole_flips
                                                                     and f.min_input_angle_deg >= 26.45)],
        "pole_flips": int(sum(f.pole_flips for f in ok)),
        "boundary_edges_on_joins": n_on_joins,
        "boundary_edges": int(len(res.mesh.boundary_edges())) if measure else None,
        "non_manifold_edges": int(len(res.mesh.non_manifold_edges())) if measure else None,
        "bad_faces": [{"face": f.face, "name": f.name, "distance": f.max_distance, "message": f.message}
                      for f in res.faces if f.status == "bad"],
        "n_remeshed": int(sum(1 for f in res.faces if f.status == "remeshed")),
        "remeshed_faces": [{"face": f.face, "name": f.name, "message": f.message}
                           for f in res.faces if f.status == "remeshed"],
        "collapsed_vertices": int(sum(f.n_collapsed for f in res.faces)),
    }


def _split_crossing_chords(shell: Shell, edges, use_key, faces, ids: _Ids, cache: dict) -> tuple[int, set]:
    """Split edge-polyline chords whose (u, v) images cross another chord of the same face's dR.

    Where two trim curves meet at a small angle (bug32596's cusps) or touch (a hole tangent to the outer
    loop), their polylines can cross in (u, v) although the curves do not: dR is then no polygon and
    Triangle cannot take it. Each crossing chord is split at its middle (on b(t) in Case 1), in the
    shared polyline (so the neighbour gets the point too), up to `_CROSSING_ROUNDS` times; a face whose
    dR still crosses is left to `join_patch`'s check (the curves themselves cross: bad input).
    Returns the number of points inserted and the faces whose dR crossed; `cache` gets every face's
    projected dR where no edge of it changed since.
    """
    from ._fallback import crossing_segments

    n_points = 0
    crossed: set[int] = set()
    for f in faces:
        face = shell.faces[f]
        added: dict[int, set[int]] = {}     # edge -> ids of the points inserted for this face
        for it in range(_CROSSING_ROUNDS + 1):
            loops = _project_loops(face, _face_loops(shell, f, edges, use_key))
            bad = crossing_segments([lp[0] for lp in loops], [lp[3] for lp in loops])
            if not len(bad):
                cache[f] = loops
                break
            if it == _CROSSING_ROUNDS:
                # the curves themselves cross: take the points out again (they would only lengthen the
                # cracks along the edges of a face left unjoined)
                for key, g in added.items():
                    ed = edges[key]
                    for u in ed.uses:
                        cache.pop(u[0], None)
                    keep = ~np.isin(ed.gid, list(g))
                    n_points -= int((~keep).sum())
                    ed.points, ed.tpar, ed.gid = ed.points[keep], ed.tpar[keep], ed.gid[keep]
                crossed.discard(f)
                break
            crossed.add(f)
            ref = np.concatenate([lp[4] for lp in loops])[bad]
            items: dict[int, set[int]] = {}
            for key, cidx, fwd in ref.tolist():
                if edges[key].degenerate:
                    continue
                j = cidx if fwd else cidx - 1
                if 0 <= j < len(edges[key].points) - 1:
                    items.setdefault(key, set()).add(j)
            if not items:
                break
            for key, js in items.items():
                ed = edges[key]
                before = set(ed.gid.tolist())
                ed.points, ed.tpar, ed.gid, _ = _insert_points(ed, [(j, 0.5) for j in sorted(js)], ids,
                                                               merge=_MERGE_FRACTION)
                new = set(ed.gid.tolist()) - before
                added.setdefault(key, set()).update(new)
                for u in ed.uses:
                    cache.pop(u[0], None)
                n_points += len(new)
    return n_points, crossed


def _split_conflicting_chords(shell: Shell, results) -> int:
    """Split interior edges joining two shared boundary points that another face also has as an edge."""
    chords: dict[tuple[int, int], list[tuple[int, int, int]]] = {}
    bnd: set[tuple[int, int]] = set()
    for i, r in enumerate(results):
        if r is None:
            continue
        shared = r.gid >= 0
        t = r.triangles[shared[r.triangles].sum(axis=1) >= 2]   # only these can hold such an edge
        if not len(t):
            continue
        # every triangle on an edge between two shared points is in t: counts over t are the patch's
        e = np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
        e = e[shared[e].all(axis=1)]
        e, cnt = np.unique(e, axis=0, return_counts=True)
        g = r.gid[e]
        both = g[:, 0] != g[:, 1]
        for (a, b), (ga, gb), c in zip(e[both], g[both], cnt[both]):
            key = (int(min(ga, gb)), int(max(ga, gb)))
            if c == 2:
                chords.setdefault(key, []).append((i, int(a), int(b)))
            else:
                bnd.add(key)
    todo: dict[int, list] = {}
    for key, uses in chords.items():
        if len(uses) >= 2 or key in bnd:
            for i, a, b in uses:
                todo.setdefault(i, []).append((a, b))
    for i, edges in todo.items():
        results[i] = split_edges(shell.faces[i], results[i], np.array(edges))
    return sum(len(v) for v in todo.values())


def _insert_points(ed: EdgePolyline, items, ids: _Ids, *, merge: float):
    """Insert points at (segment j, fraction f) into an edge polyline; new ids.

    Points closer than `merge` (a fraction of their segment) to an earlier
    point or to a segment end are not inserted. Returns the new points,
    parameters and ids, and for every item the id of the point it became
    (-1 if dropped).
    """
    points, tpar, gid = ed.points, ed.tpar, ed.gid
    order = sorted(range(len(items)), key=lambda k: (int(items[k][0]), float(items[k][1])))
    item_gid = [-1] * len(items)
    new_p, new_t, new_g = [points[0]], [tpar[0]], [gid[0]]
    it = 0
    for j in range(len(points) - 1):
        last_f, last_g = 0.0, -1
        while it < len(order) and int(items[order[it]][0]) == j:
            k = order[it]
            f = float(items[k][1])
            it += 1
            if not 0.0 < f < 1.0:
                continue
            # the two faces' points for one split land at slightly different fractions (their (u, v) differ)
            if f - last_f < merge or 1.0 - f < merge:
                item_gid[k] = last_g if f - last_f < merge else -1
                continue
            tt = tpar[j] + f * (tpar[j + 1] - tpar[j])
            if ed.case == 1 and ed.curve is not None and not ed.degenerate:
                p = ed.curve.evaluate([tt])[0]        # on b(t) itself (Case 1)
            else:
                p = points[j] + f * (points[j + 1] - points[j])
            g = gid[0] if ed.degenerate else int(ids.new(p[None])[0])
            new_p.append(p)
            new_t.append(tt)
            new_g.append(g)
            item_gid[k] = g
            last_f, last_g = f, g
        new_p.append(points[j + 1])
        new_t.append(tpar[j + 1])
        new_g.append(gid[j + 1])
    return np.array(new_p), np.array(new_t), np.array(new_g, dtype=np.int64), item_gid


def _finalize_steiner(shell: Shell, edges, use_key, results, inserts, ids: _Ids, face_loops) -> int:
    """Share the last pass's dR points with the neighbours by splitting, then reproject the touched faces."""
    from ._patch import split_boundary_edge

    touched: set[int] = set()
    n_points = 0
    for key, items in inserts.items():
        ed = edges[key]
        if ed.degenerate:
            for _, _, f, v in items:   # a pole: every point is the pole
                results[f] = results[f]._replace(gid=_with(results[f].gid, v, ed.gid[0]))
                touched.add(f)
            continue
        old_gid = ed.gid.copy()
        ed.points, ed.tpar, ed.gid, item_gid = _insert_points(ed, [(j, f) for j, f, _, _ in items], ids,
                                                              merge=_FINAL_MERGE)
        n_points += len(ed.gid) - len(old_gid)
        # own points: the vertex Triangle made becomes the shared point
        own: dict[int, set[int]] = {}
        for (j, f, face, v), g in zip(items, item_gid):
            if g < 0:
                continue
            r = results[face]
            results[face] = r._replace(gid=_with(r.gid, v, g))
            own.setdefault(face, set()).add(g)
            touched.add(face)
        # every face on the edge: insert the points it lacks by splitting its boundary triangles
        pos = {int(g): k for k, g in enumerate(ed.gid)}
        side: dict[int, int] = {}     # a seam edge is used twice by one face: each side gets the points
        for f, li, si, fwd in ed.uses:
            r = results[f]
            if r is None:
                continue
            side[f] = side.get(f, 0) + 1
            need = side[f]
            sel = np.flatnonzero(np.isin(r.gid, ed.gid))
            copies: dict[int, list[int]] = {}   # a point F has twice (a seam; a hole touching the outer loop)
            for g_, v_ in zip(r.gid[sel].tolist(), sel.tolist()):
                copies.setdefault(g_, []).append(v_)
            for k, g in enumerate(ed.gid):
                g = int(g)
                if len(copies.get(g, ())) >= need:
                    continue
                # the neighbours of g along the edge that F has
                left = next(int(x) for x in ed.gid[:k][::-1] if int(x) in copies)
                right = next(int(x) for x in ed.gid[k + 1:] if int(x) in copies)
                a, b = copies[left][-1], copies[right][-1]
                if len(copies[left]) > 1 or len(copies[right]) > 1:
                    # the copies that are the ends of one edge of F's triangles (this side's)
                    t = r.triangles
                    a, b = next(((x, y) for x in copies[left] for y in copies[right]
                                 if np.any((t == x).any(axis=1) & (t == y).any(axis=1))), (a, b))
                fa = pos[left]
                fb = pos[right]
                w = (pos[g] - fa) / max(fb - fa, 1)  # by position along the polyline (refined below)
                p_a, p_b, p_g = ed.points[fa], ed.points[fb], ed.points[pos[g]]
                den = float(np.dot(p_b - p_a, p_b - p_a))
                if den > 0:
                    w = float(np.clip(np.dot(p_g - p_a, p_b - p_a) / den, 0.0, 1.0))
                r, v = split_boundary_edge(r, a, b, (1 - w) * r.uv[a] + w * r.uv[b])
                # its triangles were split, not refined: the angle bound is not claimed for this face
                r = r._replace(gid=_with(r.gid, v, g), boundary_steiner_allowed=False)
                copies.setdefault(g, []).append(v)
            results[f] = r
            touched.add(f)
    for f in sorted(touched):
        if results[f] is not None:
            results[f] = _reproject_face(shell, f, edges, use_key, results[f])
    return n_points


def _min_corner_angle(loops_uv, scale) -> float:
    """Smallest interior corner angle (deg) of the dR loops in the working metric w = uv * scale."""
    out = 180.0
    for lp in loops_uv:
        w = lp * scale
        u = np.roll(w, 1, axis=0) - w
        v = np.roll(w, -1, axis=0) - w
        ang = np.degrees(np.arctan2(np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]), (u * v).sum(axis=1)))
        out = min(out, float(ang.min(initial=180.0)))
    return out


def _with(arr: np.ndarray, i: int, value) -> np.ndarray:
    out = arr.copy()
    out[i] = value
    return out


def _reproject_face(shell: Shell, f: int, edges, use_key, r):
    """Step 5 again on a patch whose dR gained points: exact Whitney average of the new boundary data."""
    from ..geom.whitney import boundary_data, whitney_average

    face = shell.faces[f]
    loops = _project_loops(face, _face_loops(shell, f, edges, use_key))
    uv = r.uv.copy()
    heights_ = r.heights.copy()
    points = r.points.copy()
    on_r = np.zeros(len(uv), dtype=bool)
    vid: dict[int, list[int]] = {}
    for v in np.flatnonzero(r.gid >= 0).tolist():
        vid.setdefault(int(r.gid[v]), []).append(v)
    for luv, lxyz, leps, lgid, _ in loops:
        for k, g in enumerate(lgid):
            for v in vid.get(int(g), []):
                if len(vid[int(g)]) == 1:   # a pole keeps its vertices' (u, v)
                    uv[v] = luv[k]
                heights_[v] = leps[k]
                points[v] = lxyz[k]
                on_r[v] = True
    bd = boundary_data([lp[0] * r.scale for lp in loops], [lp[2] for lp in loops])
    inner = ~on_r
    wa = whitney_average(bd, uv[inner] * r.scale)
    eta, foot, nrm = heights(face, uv[inner], points[inner])
    heights_[inner] = wa.average
    points[inner] = foot + wa.average[:, None] * nrm
    eps_all = np.concatenate([lp[2] for lp in loops])
    return r._replace(uv=uv, heights=heights_, points=points, boundary=bd, lipschitz=float(wa.lipschitz),
                      eps_max=float(np.abs(eps_all).max()))


def _merge(shell: Shell, meshes, results, reports, gpos) -> tuple[TriMesh, list]:
    """Step 6 across faces: shared boundary ids become one vertex; bad faces keep their own mesh."""
    verts = [gpos]
    n = len(gpos)
    used_g = np.zeros(len(gpos), dtype=bool)
    tris, fids, vertex_of = [], [], []
    for i, face in enumerate(shell.faces):
        r = results[i]
        if r is None:
            m = meshes[i]
            if m.n_triangles == 0:
                vertex_of.append(None)
                continue
            idx = n + np.arange(m.n_vertices)
            verts.append(m.vertices)
            n += m.n_vertices
            tris.append(idx[m.triangles])
            fids.append(np.full(m.n_triangles, i))
            vertex_of.append(idx)
            continue
        local = r.gid < 0
        idx = np.empty(len(r.uv), dtype=np.int64)
        idx[~local] = r.gid[~local]
        used_g[r.gid[~local]] = True
        idx[local] = n + np.arange(int(local.sum()))
        verts.append(r.points[local])
        n += int(local.sum())
        t = idx[r.triangles]
        if not face.same_sense:
            t = t[:, ::-1]
        ok = (t[:, 0] != t[:, 1]) & (t[:, 1] != t[:, 2]) & (t[:, 0] != t[:, 2])  # collapsed at a pole
        tris.append(t[ok])
        fids.append(np.full(int(ok.sum()), i))
        vertex_of.append(idx)
    v = np.concatenate(verts)
    t = np.concatenate(tris) if tris else np.zeros((0, 3), dtype=np.int64)
    fid = np.concatenate(fids) if fids else np.zeros(0, dtype=np.int64)
    # drop shared ids no face used (edges of bad faces only)
    used = np.zeros(len(v), dtype=bool)
    used[t.ravel()] = True
    remap = np.full(len(v), -1, dtype=np.int64)
    remap[used] = np.arange(int(used.sum()))
    vertex_of = [None if x is None else remap[x] for x in vertex_of]
    try:
        out = TriMesh(v[used], remap[t], face_id=fid)
    except MeshError as exc:  # pragma: no cover - a bug, not bad input
        raise RuntimeError(f"join: merged mesh is invalid: {exc}") from exc
    return out, vertex_of

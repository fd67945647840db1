"""Tessellation of a whole shell: conforming (shared B-rep edges discretized once) or loose (stitched)."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..model import Shell, TriMesh
from ..model.mesh import compact_indices
from .face import (ASPECT, FaceMesh, _rectangle_face, check_aspect, check_parameters, face_domain_values, loose_chunks,
                   mesh_face_from_chunks, shell_domain_values)
from .repair import quick_repairs, repair_face
from .trims import Chunk, ChunkUse, discretize_chunks

__all__ = ["TessellationResult", "FaceStatus", "tessellate_shell", "default_parameters"]

#: default tolerance and grid size, relative to the bounding-box diagonal
REL_TOLERANCE = 1e-3
REL_MAX_EDGE = 0.03


#: the tolerance the faces' grids, triangles and seam collapses are checked against, x the given one:
#: those checks sample each triangle at 7 points (centroid, edge midpoints, corner sub-centroids) and miss
#: what lies between; the measurement's refined sampling (`quality.refine_deviation`) found a CDT triangle
#: at the trim of gmsh__wing_fuselage.step at 1.0036 x the tolerance with 1.0 here
SAMPLING_MARGIN = 0.97

def default_parameters(shell: Shell) -> tuple[float, float]:
    """Default (tolerance, max_edge) from the shell's bounding-box diagonal D.

    tolerance = 1e-3 D: invisible at full-model zoom (a pixel of an 1000-pixel
    view spans about D / 1000) and the deviation Open CASCADE's own default
    relative deflection aims at. max_edge = 0.03 D: about 33 iso-lines across the
    model, enough for reflection lines to stay straight on flat panels; it is
    the chord step sqrt(8 R tolerance) of a radius R = D / 9, so on parts curved
    more tightly than that the tolerance, not the grid size, sets the spacing.

    Examples
    --------
    >>> from trimsurf.samples import build_sample
    >>> tol, h = default_parameters(build_sample("bspline_box"))
    >>> round(h / tol)
    30
    """
    d = shell.diagonal()
    if not (np.isfinite(d) and d > 0):
        raise InputError(f"{shell.name or 'shell'}: cannot derive defaults from a bounding-box diagonal of {d!r}")
    return REL_TOLERANCE * d, REL_MAX_EDGE * d


@dataclass(frozen=True)
class FaceStatus:
    """What became of one face: ``status`` in {"ok", "repaired", "flagged", "failed"}."""

    index: int
    name: str
    status: str
    messages: tuple = ()
    triangles: int = 0
    crossed_cells: int = 0
    grid: tuple = (0, 0)


@dataclass(frozen=True, eq=False)
class TessellationResult:
    """The tessellation of a shell.

    Attributes
    ----------
    mesh : TriMesh
        All faces in one mesh, with ``face_id``; vertices shared between faces
        along shared edges (conforming) or after stitching (loose).
    face_meshes : tuple of TriMesh or None
        Each face's own mesh with ``uv`` (None for a failed face).
    faces : tuple of FaceStatus
    report : dict
        Parameters, per-face status and (with ``measure=True``) the quality figures.
    tolerance, max_edge : float
    mode : {"conforming", "loose"}
    quads : (q, 2) int64
        Pairs of triangles of `mesh` that are untouched grid cells (the quads of ``--quads``).
    """

    mesh: TriMesh
    face_meshes: tuple
    faces: tuple
    report: dict
    tolerance: float
    max_edge: float
    mode: str
    quads: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), dtype=np.int64))

    @property
    def ok(self) -> bool:
        """No face failed."""
        return all(f.status != "failed" for f in self.faces)

    @property
    def failed_faces(self) -> list:
        return [f for f in self.faces if f.status == "failed"]

    def to_table(self) -> list[dict]:
        """The report as a one-row table (a list with one flat dict) that ``pandas.DataFrame`` accepts."""
        from ..viz._notebook import report_table  # viz is a higher layer: imported on use only
        return report_table(self)

    def _repr_html_(self) -> str:
        """Jupyter: the interactive viewer inline (offline) and the report's key figures."""
        from ..viz._notebook import repr_html
        return repr_html(self)


_TASK = None     # the function a forked worker runs (inherited at fork time, never pickled)


def _run_task(item):
    return _TASK(item)


def parallel_map(fn, items, jobs: int) -> list:
    """[fn(x) for x in items], in `jobs` worker processes (forked: they see the caller's data as it is
    when the pool starts; items and results are pickled), threads where fork is unavailable.

    The result is the sequential one whatever `jobs`: each item is computed by the same code from the
    same data and the results come back in the items' order.
    """
    items = list(items)
    if jobs <= 1 or len(items) < 2:
        return [fn(x) for x in items]
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor

    jobs = min(jobs, len(items))
    if "fork" not in multiprocessing.get_all_start_methods():
        with ThreadPoolExecutor(max_workers=jobs) as ex:
            return list(ex.map(fn, items))
    global _TASK
    _TASK = fn
    try:
        with ProcessPoolExecutor(max_workers=jobs, mp_context=multiprocessing.get_context("fork")) as ex:
            return list(ex.map(_run_task, items, chunksize=max(1, len(items) // (4 * jobs))))
    finally:
        _TASK = None


def _ptol(face) -> float:
    (u0, u1), (v0, v1) = face.surface.domain
    return 1e-7 * min(u1 - u0, v1 - v0)


def _conforming_chunks(shell: Shell, faces: list, grids: dict, *, tolerance: float, max_edge: float,
                       strategy: str, reduce: bool, next_id: list, jobs: int = 1):
    """Discretize every shared edge once; returns per face, per loop, the (chunk, use, ids) entries."""
    entries: dict = {i: [[None] * len(faces[i].loops[li].segments) for li in range(len(faces[i].loops))]
                     for i in grids}
    ptol = {fi: _ptol(faces[fi]) for fi in grids}
    edge_uses, shared = [], set()
    for ei, edge in enumerate(shell.edges):
        uses = []
        for (fi, li, si) in edge.uses:
            row = entries.get(fi)
            if row is None or li >= len(row) or si >= len(row[li]):
                continue
            seg = faces[fi].loops[li].segments[si]
            if seg.edge_id != ei:
                continue
            us, vs = grids[fi]
            uses.append(ChunkUse(fi, li, si, seg, faces[fi].surface, us, vs, ptol[fi]))
            shared.add((fi, li, si))
        if uses:
            edge_uses.append((ei, uses))
    # the same for the segments without an edge (filled gaps, faces without topology): their own chunk
    own = []
    for fi in grids:
        us, vs = grids[fi]
        for li, loop in enumerate(faces[fi].loops):
            for si, seg in enumerate(loop.segments):
                if (fi, li, si) not in shared:
                    own.append((fi, li, si, ChunkUse(fi, li, si, seg, faces[fi].surface, us, vs, ptol[fi])))

    # every chunk in one compiled call (`trims.discretize_chunks`); with jobs, one call per contiguous part
    all_uses = [u for _, u in edge_uses] + [[o[3]] for o in own]
    all_deg = [True if shell.edges[ei].is_degenerate else None for ei, _ in edge_uses] + [None] * len(own)
    n_parts = max(1, min(jobs, len(all_uses) // 16))
    if n_parts == 1:        # in this process: discretize_chunks' own Chunk objects (the same uses)
        chunks = discretize_chunks(all_uses, tolerance=tolerance, max_edge=max_edge, strategy=strategy,
                                   reduce=reduce, degenerate=all_deg)
    else:
        cuts = np.linspace(0, len(all_uses), n_parts + 1).astype(np.int64)

        def discretize(k):
            a, b = int(cuts[k]), int(cuts[k + 1])
            return [(ch.s, ch.uv, ch.xyz, ch.is_iso, ch.degenerate)
                    for ch in discretize_chunks(all_uses[a:b], tolerance=tolerance, max_edge=max_edge,
                                                strategy=strategy, reduce=reduce, degenerate=all_deg[a:b])]

        out = [r for part in parallel_map(discretize, range(n_parts), jobs) for r in part]
        chunks = [Chunk(s_, list(uses), uv, xyz, iso, deg) for (s_, uv, xyz, iso, deg), uses in zip(out, all_uses)]
    ne = len(edge_uses)
    ids_e = _edge_point_ids(shell, [ei for ei, _ in edge_uses], chunks[:ne], tolerance, next_id)
    for (ei, uses), chunk, ids in zip(edge_uses, chunks, ids_e):
        for ui, use in enumerate(uses):
            entries[use.face][use.loop][use.segment] = (chunk, ui, ids)
    if not own:
        return entries
    # segments without an edge (discretized above with the edges): one shorter
    # than the tolerance in 3D (a filled gap, a suit-case corner) is one vertex: its neighbours' joint
    def end_id(entry, at_end: bool):
        ch, ui, ids = entry
        fwd = ch.uses[ui].forward
        return int(ids[-1] if fwd == at_end else ids[0])

    pending = []
    for (fi, li, si, _), chunk in zip(own, chunks[ne:]):
        ids = np.arange(next_id[0], next_id[0] + len(chunk.s), dtype=np.int64)
        next_id[0] += len(chunk.s)
        if chunk.degenerate:
            ids[:] = ids[0]
        entries[fi][li][si] = (chunk, 0, ids)
        if float(np.linalg.norm(chunk.xyz - chunk.xyz[0], axis=1).max()) <= tolerance:
            pending.append((fi, li, si))
    for fi, li, si in pending:
        loop = entries[fi][li]
        n = len(loop)
        prev, nxt = loop[(si - 1) % n], loop[(si + 1) % n]
        if (fi, li, (si - 1) % n) in pending or (fi, li, (si + 1) % n) in pending:
            continue
        ch, ui, ids = loop[si]
        a, b = end_id(prev, True), end_id(nxt, False)
        new = np.full(len(ids), a, dtype=np.int64)
        if ch.uses[ui].forward:
            new[-1] = b
        else:
            new[0] = b
        loop[si] = (ch, ui, new)
    return entries


def _edge_point_ids(shell: Shell, edge_index: list, chunks: list, tolerance: float, next_id: list) -> list:
    """The global vertex ids of the edges' points (one array per chunk, views of one array), numbered
    as `_edge_point_ids_loop` numbers them, edge by edge: the edge's k points, then its end vertices
    that have no id yet (the one at the edge's start first). The ends are the shell's vertices, in the
    edge's own direction (vertices[0] at t0); a closed edge without vertices ends on its first id; a
    degenerate edge is one id. Advances next_id[0]."""
    n = len(chunks)
    if not n:
        return []
    k = np.fromiter((len(ch.s) for ch in chunks), dtype=np.int64, count=n)
    edges = [shell.edges[ei] for ei in edge_index]
    # per edge its end vertices (a at the chunk's first point, b at its last), -1: none
    ab = np.array([e.vertices if e.t0 <= e.t1 else e.vertices[::-1] for e in edges], dtype=np.int64).reshape(n, 2)
    seq = ab.ravel()
    pos = np.flatnonzero(seq >= 0)
    uniq, first, inv = np.unique(seq[pos], return_index=True, return_inverse=True)
    is_new = np.zeros(2 * n, dtype=np.int64)
    is_new[pos[first]] = 1
    new = is_new.reshape(n, 2)
    step = k + new.sum(axis=1)
    base = next_id[0] + np.concatenate(([0], np.cumsum(step)[:-1]))
    ids = np.arange(int(step.sum()), dtype=np.int64) + next_id[0]
    # the points' ids: base_c .. base_c + k_c - 1 (the gaps after them are the new vertices' ids)
    slot_id = np.full(2 * n, -1, dtype=np.int64)
    vid = (base[:, None] + k[:, None] + np.column_stack([np.zeros(n, dtype=np.int64), new[:, 0]])).ravel()
    slot_id[pos] = vid[pos[first]][inv]
    next_id[0] += int(step.sum())
    start = base - int(base[0])
    last = start + k - 1
    sid = slot_id.reshape(n, 2)
    has_a, has_b = sid[:, 0] >= 0, sid[:, 1] >= 0
    ids[start[has_a]] = sid[has_a, 0]
    ids[last[has_b]] = sid[has_b, 1]
    for c in np.flatnonzero(~has_a & ~has_b).tolist():       # closed edges without vertices (rare)
        if np.linalg.norm(chunks[c].xyz[0] - chunks[c].xyz[-1]) <= 1e-3 * tolerance:
            ids[last[c]] = ids[start[c]]
    deg = np.fromiter((ch.degenerate for ch in chunks), dtype=bool, count=n)
    if deg.any():
        st, kd = start[deg], k[deg]
        ids[np.repeat(st, kd) + (np.arange(int(kd.sum())) - np.repeat(np.cumsum(kd) - kd, kd))] = np.repeat(ids[st], kd)
    return [ids[a:b] for a, b in zip(start.tolist(), (start + k).tolist())]


def _edge_point_ids_loop(shell: Shell, edge_index: list, chunks: list, tolerance: float, next_id: list) -> list:
    """`_edge_point_ids` edge by edge (the reference the tests compare it with)."""
    vertex_ids = {}

    def vid_of(shell_vertex: int):
        if shell_vertex < 0:
            return None
        if shell_vertex not in vertex_ids:
            vertex_ids[shell_vertex] = next_id[0]
            next_id[0] += 1
        return vertex_ids[shell_vertex]

    out = []
    for ei, chunk in zip(edge_index, chunks):
        edge = shell.edges[ei]
        k = len(chunk.s)
        ids = np.arange(next_id[0], next_id[0] + k, dtype=np.int64)
        next_id[0] += k
        lo_first = edge.t0 <= edge.t1
        a, b = (edge.vertices if lo_first else edge.vertices[::-1])
        ia, ib = vid_of(a), vid_of(b)
        if ia is not None:
            ids[0] = ia
        if ib is not None:
            ids[-1] = ib
        if ia is None and ib is None and np.linalg.norm(chunk.xyz[0] - chunk.xyz[-1]) <= 1e-3 * tolerance:
            ids[-1] = ids[0]            # a closed edge without vertices
        if chunk.degenerate:
            ids[:] = ids[0]
        out.append(ids)
    return out


def tessellate_shell(shell: Shell, *, tolerance: float | None = None, max_edge: float | None = None,
                     mode: str = "auto", strategy: str = "equidistributed", reduce: bool = True,
                     stitch: bool = True, reduce_seams: bool = True, common: bool = False,
                     measure: bool = True, progress=None, jobs: int = 1,
                     aspect: float | None = ASPECT) -> TessellationResult:
    """Tessellate every face of a shell and join them into one mesh (paper Sec. 4-5).

    Parameters
    ----------
    shell : Shell
    tolerance : float or None
        Max. geometric deviation (model units); default `default_parameters`.
    max_edge : float or None
        Max. 3D grid size (model units); default `default_parameters`.
    mode : {"auto", "conforming", "loose"}
        "conforming": every shared B-rep edge is discretized once and both faces
        get the same points (watertight by construction on a closed shell);
        "loose": faces are tessellated separately and stitched (paper Sec. 4.4-4.6);
        "auto": conforming when faces share edges (B-rep topology) or there is one face, else loose.
    strategy : {"equidistributed", "bisection", "uniform"}
        Domain values (`trimsurf.tessellate.domain`).
    reduce : bool
        Trim-polygon reduction (paper Sec. 5.1).
    stitch, reduce_seams : bool
        Loose mode: stitch adjacent faces; reduce the stitched seams by edge collapse
        (conforming mode: reduce the seams too, and stitch what Triangle left open).
    common : bool
        Conforming mode: common parameterization of faces meeting along
        iso-parametric edges (`trimsurf.tessellate.common`, paper Fig. 12).
        Only faces meeting tangent-continuously (normals within 10 deg) are
        linked. Off by default: watertight on every real model measured, at
        1.00-1.22x the triangles (CLI ``--common``).
    measure : bool
        Measure the quality figures of the result (deviation by dense sampling,
        angles, topology, flips) into ``report``.
    progress : callable or None
        Called with (done, total) after each face.
    jobs : int
        Worker processes for the per-face and per-edge stages (repair and domain values, edge
        discretization, face triangulation); threads where the platform cannot fork. The output is
        the same whatever `jobs` (each face and edge is computed by the same code from the same data,
        results are joined in order). The workers are forked: from a process that runs other threads
        (a Dask worker, a GUI) keep ``jobs=1``.
    aspect : float or None
        Largest side ratio (3D) of a grid cell at the trimmed region: a longer cell is halved
        across its long side (where the short side's direction has at least two cells), so that
        its two triangles' smallest angle stays above about atan(1 / aspect). Not the paper's
        (its grid size, `max_edge`, keeps the cells regular); it binds mostly where the grid size does
        not, i.e. with a large `max_edge`. Default `face.ASPECT` (6); None or inf: no limit
        (fewer, thinner triangles; CLI ``--max-aspect``). With `face.LIMIT_DEVELOPABLE` False,
        developable faces (planes, cylinders, cones, extrusions: the normal is the same all along
        their straight lines, so cells long along those lines shade exactly) are not limited.

    Returns
    -------
    TessellationResult
        Faces that repair cannot fix are skipped and listed with status "failed".

    Raises
    ------
    InputError
        Not a shell, no faces, bad parameters or mode.

    Examples
    --------
    >>> from trimsurf.samples import build_sample
    >>> res = tessellate_shell(build_sample("bspline_box"), measure=False)
    >>> res.mode, res.ok, res.mesh.is_watertight()
    ('conforming', True, True)
    """
    t_start = time.perf_counter()
    if not isinstance(shell, Shell):
        raise InputError(f"tessellate_shell needs a Shell; got {type(shell).__name__}")
    if not shell.faces:
        raise InputError(f"{shell.name or 'shell'}: no faces to tessellate")
    if isinstance(jobs, bool) or not isinstance(jobs, (int, np.integer)) or jobs < 1:
        raise InputError(f"jobs must be a positive integer; got {jobs!r}")
    jobs = int(jobs)
    aspect = check_aspect(aspect)
    if mode not in ("auto", "conforming", "loose"):
        raise InputError(f"mode must be 'auto', 'conforming' or 'loose'; got {mode!r}")
    d_tol, d_h = (None, None) if tolerance is not None and max_edge is not None else default_parameters(shell)
    tolerance, max_edge = check_parameters(d_tol if tolerance is None else tolerance,
                                           d_h if max_edge is None else max_edge)
    if mode == "auto":      # conforming when faces share B-rep edges (an unsewn IGES has only free edges)
        shared = any(len(e.uses) >= 2 for e in shell.edges)
        mode = "conforming" if shared or len(shell.faces) == 1 else "loose"
    # loose mode: faces within half the tolerance, stitching moves vertices by at most the other half
    # (conforming: x SAMPLING_MARGIN, the faces' own checks sample each triangle at a few points)
    face_tol = SAMPLING_MARGIN * tolerance if mode == "conforming" else 0.5 * tolerance
    n = len(shell.faces)
    faces, statuses = [], {}
    grids: dict = {}
    fits: dict = {}     # per face (us, vs, the grid's diagonal fits) from face_domain_values

    quick = quick_repairs(shell.faces, tolerance=face_tol)     # the faces repair leaves as they are, batched

    def prepare(i):     # repair and domain values of face i: (face, status, grid or None)
        face = shell.faces[i]
        name = face.name or f"face {i}"
        rep = quick[i] if quick[i] is not None else repair_face(face, tolerance=face_tol)
        f = rep.face
        if rep.status == "failed":
            return f, FaceStatus(i, name, "failed", tuple(rep.messages)), None
        if not f.loops:
            f = _rectangle_face(f)
        try:
            grid = face_domain_values(f, tolerance=face_tol, max_edge=max_edge, strategy=strategy, with_fits=True,
                                      aspect=aspect)
            return f, FaceStatus(i, name, rep.status, tuple(rep.messages)), grid
        except InputError as exc:
            return f, FaceStatus(i, name, "failed", tuple(rep.messages) + (str(exc),)), None

    def prepare_face(i):    # a face repair left as it was comes back as None (not copied back)
        f, st, grid = prepare(i)
        return (None if f is shell.faces[i] else f), st, grid

    if jobs <= 1:   # the repairs, then the domain values of all faces at once (`shell_domain_values`)
        prepared = []
        for i in range(n):
            face = shell.faces[i]
            rep = quick[i] if quick[i] is not None else repair_face(face, tolerance=face_tol)
            f = rep.face
            if rep.status != "failed" and not f.loops:
                f = _rectangle_face(f)
            prepared.append((f, rep))
        todo = [i for i in range(n) if prepared[i][1].status != "failed"]
        values = dict(zip(todo, shell_domain_values([prepared[i][0] for i in todo], tolerance=face_tol,
                                                    max_edge=max_edge, strategy=strategy, aspect=aspect)))
        results = []
        for i, (f, rep) in enumerate(prepared):
            name = shell.faces[i].name or f"face {i}"
            grid = values.get(i)
            if rep.status == "failed":
                results.append((f, FaceStatus(i, name, "failed", tuple(rep.messages)), None))
            elif isinstance(grid, InputError):
                results.append((f, FaceStatus(i, name, "failed", tuple(rep.messages) + (str(grid),)), None))
            else:
                results.append((f, FaceStatus(i, name, rep.status, tuple(rep.messages)), grid))
    else:
        results = [(shell.faces[i] if f is None else f, st, grid)
                   for i, (f, st, grid) in enumerate(parallel_map(prepare_face, range(n), jobs))]
    for i, (f, st, grid) in enumerate(results):
        faces.append(f)
        statuses[i] = st
        if grid is not None:
            grids[i] = grid[:2]
            fits[i] = grid
    n_common = 0
    if common and mode == "conforming":
        from .common import common_parameterization
        from .face import face_aspect, refine_cells

        changed = common_parameterization(shell, faces, grids)
        n_common = len(changed)
        for i in changed:
            us, vs = grids[i]
            grids[i] = refine_cells(faces[i], us, vs, tolerance=face_tol, max_edge=max_edge,
                                    aspect=face_aspect(faces[i], aspect))
    face_meshes: dict = {}
    next_id = [0]
    if mode == "conforming":
        entries = _conforming_chunks(shell, faces, grids, tolerance=tolerance, max_edge=max_edge,
                                     strategy=strategy, reduce=reduce, next_id=next_id, jobs=jobs)
    def mesh_face(i):   # the triangulation of face i, or the InputError that stopped it
        us, vs = grids[i]
        # the domain values' diagonal fits while the grid is still theirs (common_parameterization replaces some)
        known = fits.get(i)
        f_i = known[2] if known is not None and known[0] is us and known[1] is vs else None
        try:
            if mode == "conforming":
                return mesh_face_from_chunks(faces[i], us, vs, entries[i], tolerance=face_tol, max_edge=max_edge,
                                             fits=f_i)
            return mesh_face_from_chunks(faces[i], us, vs,
                                         loose_chunks(faces[i], i, us, vs, tolerance=face_tol,
                                                      max_edge=max_edge, strategy=strategy, reduce=reduce),
                                         tolerance=face_tol, max_edge=max_edge, fits=f_i)
        except InputError as exc:
            return exc

    done = 0
    order = sorted(grids)
    # one job: face by face, so that `progress` follows the work
    for i, fm in zip(order, map(mesh_face, order) if jobs <= 1 else parallel_map(mesh_face, order, jobs)):
        us, vs = grids[i]
        try:
            if isinstance(fm, InputError):
                raise fm
            face_meshes[i] = fm
            st = statuses[i]
            status, msgs = st.status, st.messages
            if fm.removed_loop_points:
                status = "repaired" if status == "ok" else status
                msgs = msgs + (f"{st.name}: a trim loop crosses itself; its smaller sub-loop "
                               f"({fm.removed_loop_points} polygon points) was cut out",)
            statuses[i] = FaceStatus(i, st.name, status, msgs, int(len(fm.triangles)),
                                     fm.n_crossed_cells, (len(us) - 1, len(vs) - 1))
        except InputError as exc:
            st = statuses[i]
            statuses[i] = FaceStatus(i, st.name, "failed", st.messages + (str(exc),))
        done += 1
        if progress is not None:
            progress(done, n)
    stitch_info: dict = {}
    quads = np.zeros((0, 2), dtype=np.int64)
    if mode == "conforming":
        # with seam reduction (corner (u, v) and surfaces given) the bounds are not read: not computed
        mesh, quads, tri_dev, corner_uv = _assemble_conforming(face_meshes, next_id[0], with_dev=not reduce_seams)
        if reduce_seams:
            from .seams import reduce_seams as _reduce_seams

            n_before = mesh.n_triangles
            mesh, n_coll, keep_tri = _reduce_seams(mesh, SAMPLING_MARGIN * tolerance, tri_dev=tri_dev,
                                                   max_edge=max_edge,
                                                   corner_uv=corner_uv,
                                                   surfaces=[f.surface for f in faces], faces=faces,
                                                   return_kept=True)
            stitch_info["seam_collapses"] = n_coll
            stitch_info["triangles_before_seam_reduction"] = n_before
            if len(quads):
                new_index = np.full(n_before, -1, dtype=np.int64)
                new_index[keep_tri] = np.arange(int(keep_tri.sum()))
                quads = new_index[quads]
                quads = quads[(quads >= 0).all(axis=1)]
            tri_dev = None
        if len(mesh.boundary_edges()) and stitch:
            # safety net: T-junctions the conforming path left (a point Triangle had to insert on a trim)
            from .stitch import stitch_mesh

            n_before = mesh.n_triangles
            mesh, st, _, origin = stitch_mesh(mesh, 0.5 * tolerance, tri_dev, return_origin=True)
            stitch_info.update({f"repair_{k}": v for k, v in st.items()})
            if len(quads):
                new_index = np.full(n_before, -1, dtype=np.int64)
                kept = origin >= 0
                new_index[origin[kept]] = np.flatnonzero(kept)
                quads = new_index[quads]
                quads = quads[(quads >= 0).all(axis=1)]
    elif not face_meshes:  # loose mode with every face failed: nothing to merge (the CLI says so, exit 1)
        mesh = TriMesh(np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64))
        stitch_info["faces_collapsed"] = []
    else:
        from .orient import orient_meshes
        from .stitch import merge_face_meshes

        mesh, stitch_info = merge_face_meshes(face_meshes, tolerance=tolerance, stitch=stitch,
                                              reduce_seams=reduce_seams, max_edge=max_edge,
                                              faces=[faces[i] if i in face_meshes else None
                                                     for i in range(n)])
        quads = stitch_info.pop("quads")
        mesh, flipped_faces = orient_meshes(mesh)
        stitch_info["faces_flipped"] = flipped_faces
        # a face smaller than the stitching distance can merge into its neighbours' triangles: said
        # so in its entry (the measure module measures its distance to the mesh)
        present = set(np.unique(mesh.face_id).tolist()) if mesh.n_triangles else set()
        collapsed = [i for i in sorted(face_meshes) if i not in present]
        for i in collapsed:
            st = statuses[i]
            statuses[i] = FaceStatus(i, st.name, st.status, st.messages + (
                f"{st.name}: smaller than the stitching distance; merged into its neighbours' triangles",),
                0, st.crossed_cells, st.grid)
        stitch_info["faces_collapsed"] = collapsed
    fm_out = _face_trimeshes(face_meshes, n)
    faces_t = tuple(statuses[i] for i in range(n))
    report = {
        "mode": mode, "strategy": strategy, "tolerance": tolerance, "max_edge_used": max_edge,
        "parameters": {"tolerance": tolerance, "max_edge": max_edge, "aspect": aspect},
        "faces_in": n, "faces_failed": sum(f.status == "failed" for f in faces_t),
        "faces_flagged": sum(f.status == "flagged" for f in faces_t),
        "faces_repaired": sum(f.status == "repaired" for f in faces_t),
        "faces_common_parameterization": n_common,
        "triangles": mesh.n_triangles, "vertices": mesh.n_vertices,
        "faces": [{"index": f.index, "name": f.name, "status": f.status, "messages": list(f.messages),
                   "triangles": f.triangles, "grid": list(f.grid), "crossed_cells": f.crossed_cells}
                  for f in faces_t],
    }
    report.update({k: v for k, v in stitch_info.items()})
    report["seconds_tessellate"] = time.perf_counter() - t_start
    result = TessellationResult(mesh, fm_out, faces_t, report, tolerance, max_edge, mode, quads)
    report["seconds_measure"] = 0.0
    if measure and mesh.n_triangles:
        from .measure import measure_result
        t_measure = time.perf_counter()
        report.update(measure_result(result, shell))
        report["seconds_measure"] = time.perf_counter() - t_measure
    report["seconds"] = time.perf_counter() - t_start
    return result


def _assemble_conforming(face_meshes: dict, n_shared: int, with_dev: bool = True) -> TriMesh:
    """One mesh: shared (chunk) vertices by their global id, face-interior vertices appended.

    Faces in increasing order; a shared vertex takes its position from the first face that has it
    (within that face, its last point with that id). All faces' arrays are joined once and indexed
    together (no per-face numpy passes). with_dev=False: the triangles' deviation bounds come as None
    (`FaceMesh.tri_dev` not computed).
    """
    order = sorted(face_meshes)
    if not order:
        return (TriMesh(np.zeros((0, 3)), np.zeros((0, 3), np.int64), face_id=np.zeros(0, np.int64)),
                np.zeros((0, 2), dtype=np.int64), np.zeros(0), np.zeros((0, 3, 2)))
    fms = [face_meshes[i] for i in order]
    nvs = np.array([len(fm.vid) for fm in fms], dtype=np.int64)
    nts = np.array([len(fm.triangles) for fm in fms], dtype=np.int64)
    voff = np.r_[0, np.cumsum(nvs)[:-1]]
    toff = np.r_[0, np.cumsum(nts)[:-1]]
    vid = np.concatenate([fm.vid for fm in fms])
    xyz = np.concatenate([fm.xyz for fm in fms])
    uv = np.concatenate([fm.uv for fm in fms])
    tri_local = np.concatenate([fm.triangles for fm in fms]).astype(np.int64, copy=False)
    tri_face = np.repeat(np.arange(len(fms)), nts)
    tri_all = tri_local + voff[tri_face][:, None]
    own = vid < 0
    gid = vid.astype(np.int64, copy=True)
    gid[own] = n_shared + np.arange(int(own.sum()))
    # a shared vertex's position: the first face that has it, its last point there
    sh = np.flatnonzero(~own)
    verts = np.zeros((n_shared, 3))
    if len(sh):
        vface = np.repeat(np.arange(len(fms)), nvs)[sh]
        pick = np.lexsort((-sh, vface, gid[sh]))
        g = gid[sh][pick]
        first = np.r_[True, g[1:] != g[:-1]]
        verts[g[first]] = xyz[sh[pick[first]]]
    t = gid[tri_all]
    ok = (t[:, 0] != t[:, 1]) & (t[:, 1] != t[:, 2]) & (t[:, 0] != t[:, 2])
    tri = t[ok]
    fid = np.asarray(order, dtype=np.int64)[tri_face[ok]]
    dev = np.concatenate([fm.tri_dev for fm in fms])[ok] if with_dev else None
    cuv = uv[tri_all[ok]]
    new_index = np.where(ok, np.cumsum(ok) - 1, -1)
    quads = [fm.quads + toff[k] for k, fm in enumerate(fms) if len(fm.quads)]
    if quads:
        q = new_index[np.concatenate(quads).astype(np.int64)]
        q = q[(q >= 0).all(axis=1)]
    else:
        q = np.zeros((0, 2), dtype=np.int64)
    allv = np.concatenate([verts, xyz[own]])
    used, inv = compact_indices(tri, len(allv))         # (np.unique(tri, return_inverse=True))
    return TriMesh(allv[used], inv.reshape(-1, 3), face_id=fid), q, dev, cuv


def _face_trimeshes(face_meshes: dict, n: int) -> tuple:
    """``tuple(face_meshes[i].to_trimesh() if i in face_meshes else None for i in range(n))``, with the
    faces' arrays copied and checked together (as `TriMesh` checks each: finite float64 coordinates and
    (u, v), int64 triangles in range without a repeated vertex), each face's mesh holding its own
    read-only copies of its rows (as `TriMesh` makes them). Anything the batch does not cover (another dtype or shape, a failed check):
    the per-face constructor, which raises its error for the first such face."""
    order = sorted(face_meshes)
    fms = [face_meshes[i] for i in order]

    def per_face():
        return tuple(face_meshes[i].to_trimesh() if i in face_meshes else None for i in range(n))
    if not fms or not all(
            isinstance(fm.xyz, np.ndarray) and isinstance(fm.uv, np.ndarray) and isinstance(fm.triangles, np.ndarray)
            and fm.xyz.dtype == np.float64 and fm.uv.dtype == np.float64 and fm.triangles.dtype == np.int64
            and fm.xyz.ndim == 2 and fm.xyz.shape[1] == 3 and fm.uv.shape == (len(fm.xyz), 2)
            and fm.triangles.ndim == 2 and fm.triangles.shape[1] == 3 for fm in fms):
        return per_face()
    nvs = [len(fm.xyz) for fm in fms]
    nts = [len(fm.triangles) for fm in fms]
    xyz = np.concatenate([fm.xyz for fm in fms])
    uv = np.concatenate([fm.uv for fm in fms])
    tri = np.concatenate([fm.triangles for fm in fms])
    if not (np.isfinite(xyz).all() and np.isfinite(uv).all()):
        return per_face()
    if len(tri):
        lim = np.repeat(np.asarray(nvs, dtype=np.int64), nts)
        if (tri.min() < 0 or np.any(tri.max(axis=1) >= lim)
                or np.any((tri[:, 0] == tri[:, 1]) | (tri[:, 1] == tri[:, 2]) | (tri[:, 0] == tri[:, 2]))):
            return per_face()
    out: list = [None] * n
    vo = to = 0

    def own(a):             # each face's own read-only copy, as `TriMesh` makes it (not a view of the batch)
        a = a.copy()
        a.setflags(write=False)
        return a
    for i, nv, nt in zip(order, nvs, nts):
        m = object.__new__(TriMesh)         # the fields `TriMesh.__post_init__` would set, checked above
        object.__setattr__(m, "vertices", own(xyz[vo:vo + nv]))
        object.__setattr__(m, "triangles", own(tri[to:to + nt]))
        object.__setattr__(m, "uv", own(uv[vo:vo + nv]))
        object.__setattr__(m, "face_id", None)
        out[i] = m
        vo += nv
        to += nt
    return tuple(out)

"""The guarantees, measured on every output with `trimsurf.quality` (never assumed)."""

from __future__ import annotations

import time
import weakref

import numpy as np

from ..errors import InputError
from ..geom.nurbs import unit_normals
from ..model import Shell, TriMesh
from ..quality import topology_report, triangle_quality
from ..quality.deviation import _shell_deviation

__all__ = ["measure_mesh", "measure_result", "flipped_against_normal", "explained_nonmanifold_edges",
           "figures_of_same_mesh"]


def flipped_against_normal(mesh: TriMesh, shell: Shell, *, reversed_faces=(), tol_rel: float = 1e-10,
                           centroid_uv=None) -> int:
    """Triangles whose normal points against their face's outward surface normal (at the centroid's foot).

    Faces in `reversed_faces` were turned by the orientation fix (their stored
    sense disagreed with their neighbours'): their triangles are checked against
    the reversed normal. `centroid_uv`: {face index: (k, 2) feet of that face's
    triangles' centroids, in the order of ``mesh.face_id == i``} where already
    projected (by the deviation's samples); other faces are projected here.

    The numbers of `quality.flipped_triangles_normal` on each face's submesh
    (``mesh.submesh(mesh.face_id == i)``: the same triangles in the same order,
    so the same normals, centroids, feet and signs), with the triangle normals
    computed once and each face's triangles taken by one stable sort instead of
    a submesh per face.
    """
    from ..quality.deviation import project_to_face
    from ..quality.sampling import as_face

    if mesh.face_id is None:
        return 0
    rev = {int(f) for f in reversed_faces}
    order = np.argsort(mesh.face_id, kind="stable")
    faces, starts = np.unique(mesh.face_id[order], return_index=True)
    ends = np.r_[starts[1:], len(order)]
    normals = mesh.triangle_normals()
    if not len(order):
        return 0
    # per face the surface's first derivatives at the feet (one evaluation per surface); the normals, their
    # dot products and signs row by row over all faces at once (`TrimmedFace.oriented_normals`' operations:
    # `geom.unit_normals`, negated where the face's sense is reversed; each row's numbers do not depend on
    # the others), and each face's counts from the signs
    su, sv, neg = [], [], np.zeros(len(order), dtype=bool)
    for i, a, b in zip(faces.tolist(), starts.tolist(), ends.tolist()):
        rows = order[a:b]
        face = as_face(shell.faces[i])
        cuv = None if centroid_uv is None else centroid_uv.get(i)
        if cuv is None:
            centroids = mesh.vertices[mesh.triangles[rows]].mean(axis=1)
            cuv = project_to_face(centroids, face, tol_rel=tol_rel).uv
        elif np.shape(cuv) != (b - a, 2):
            raise InputError(f"centroid_uv of face {i} must have shape ({b - a}, 2); got {np.shape(cuv)}")
        d = face.surface.derivatives(np.asarray(cuv, dtype=np.float64), 1)
        su.append(d[1, 0])
        sv.append(d[0, 1])
        neg[a:b] = not face.same_sense
    nrm = unit_normals(np.concatenate(su), np.concatenate(sv))
    nrm[neg] = -nrm[neg]
    dot = np.einsum("ij,ij->i", normals[order], nrm)
    sign = np.sign(np.where(np.isfinite(dot), dot, 0.0))
    k = np.repeat(np.arange(len(faces)), ends - starts)
    n_neg = np.bincount(k[sign < 0], minlength=len(faces))
    n_zero = np.bincount(k[sign == 0], minlength=len(faces))
    n = 0
    for j, (i, a, b) in enumerate(zip(faces.tolist(), starts.tolist(), ends.tolist())):
        flipped = int(n_neg[j])
        n += (b - a) - flipped - int(n_zero[j]) if i in rev else flipped
    return int(n)


def _collapsed_faces(mesh: TriMesh, shell: Shell, faces, n_domain: int) -> dict:
    """Faces left without triangles (not skipped): their largest distance to the whole mesh.

    A face smaller than the stitching distance can merge into its neighbours'
    triangles; whether that stays within the tolerance is measured from the
    face's own samples to the mesh (one-sided: it has no triangles of its own),
    never assumed. A face that would not close (no samples) gives inf.
    """
    from ..quality.closest_point import closest_points_on_mesh
    from ..quality.sampling import sample_face_domain

    out = {}
    for i in sorted(int(f) for f in faces):
        face = shell.faces[i]
        uv = sample_face_domain(face, n=n_domain)
        if not len(uv) or not mesh.n_triangles:
            out[i] = float("inf")
            continue
        pts = face.surface.evaluate(uv)
        out[i] = float(closest_points_on_mesh(pts, mesh).distance.max())
    return out


#: `shell_deviation`'s ``refine``: triangles are sampled more densely until the curvature bound between
#: the samples leaves at most this fraction above the reported maximum deviation
REFINE = 0.01


def measure_mesh(mesh: TriMesh, shell: Shell, *, density: int = 3, n_domain: int = 32, reversed_faces=(),
                 skipped_faces=(), refine: float | None = REFINE) -> dict:
    """The issue's report fields for one mesh with ``face_id`` tessellating `shell`.

    Returns
    -------
    dict
        triangles, vertices, max_deviation (two-sided, sampled: mesh points
        projected onto the true faces and face points measured to the mesh,
        `shell_deviation` with ``refine``), max_deviation_bound (the
        curvature bound between the samples, `refine_deviation`: an upper
        bound on the true deviation as far as the curvature sampled at each
        triangle's corners and centre, x1.5, bounds it; not proven),
        max_edge (longest edge), min_angle_deg,
        p5_angle_deg (5th percentile of the per-triangle smallest angle),
        boundary_edges, nonmanifold_edges, flipped (against the surface normal),
        orientation_consistent, watertight, seconds_measure.
        Faces in `skipped_faces` (reported as failed and left out of the mesh)
        are listed in ``uncovered_faces`` but do not enter the deviation
        figures; any other uncovered face (collapsed into its neighbours by
        stitching) enters with its measured distance to the whole mesh,
        listed in ``collapsed_faces``.

    Notes
    -----
    What the deviation figures bound. The samples follow the triangles:
    every triangle is sampled on a barycentric grid of k divisions per edge
    (k = `density`, raised up to 32 where needed) in both directions (mesh
    points projected onto the face's surface, with restarts that look for
    the global foot; surface points over the triangle's own (u, v)
    footprint measured exactly to the face's triangles), plus a (u, v) grid
    whose spacing is the triangles' median (u, v) extent / 2.5 (a hole one
    triangle wide holds a sample) and the `n_domain` grid. k follows the
    curvature: while its bound
    ``B_t(k) = D_t + beta_t / ((1 - kappa_t D_t) k^2)`` (D_t its largest
    sample, beta_t from the shape operator along its edges at its corners'
    feet and centre, x1.5) exceeds ``(1 + refine)`` x the maximum so far, a
    triangle is sampled again at the smallest k' whose B_t(k') meets it
    (not 2k: the refinement's samples on t20 / screw tolerance-only
    100K -> 38K / 54K -> 25K; the grids are not nested, so the maximum can
    come out a little lower than doubling's, measured -0.19% to +0.05% on
    the 34 shared runs, still within ``refine`` of the bound). So
    ``max_deviation`` is the largest sample (never above the true two-sided
    deviation, within ``refine`` of ``max_deviation_bound`` unless a
    triangle reached 32 divisions: occt__linkrods tolerance-only 1.6%), and
    ``max_deviation_bound`` bounds the true deviation provided the
    curvature sampled at each triangle's corners and centre, x1.5, bounds it
    in between and the projections find the global foot: sampled, not
    proven. A deviation confined to a region smaller than a triangle's
    sample spacing (1/32 of the triangle at the densest) whose curvature
    shows at none of those points can still pass unseen.

    Triangles skipped, with the same figures (`quality.deviation._shell_deviation`'s ``skip``):
    each triangle's a-priori bound A_t (`quality.interpolation_bound`: proven from the control net's
    second differences and the corners' distances, for both directions: its points' distance to
    the surface and the distance of the surface over its corners' feet to it) is computed for the
    faces whose domain-wide bound is at most the maxima already measured (faces are measured in
    decreasing order of that bound); a triangle with A_t at most both the mesh -> faces and the
    faces -> mesh maxima so far is not sampled (only its centroid is projected, for the flip test),
    nor are the (u, v) grid's points in its footprint: none of these samples, nor any refinement
    of it, could exceed a maximum both sides already reach, so ``max_deviation`` and its one-sided
    parts are the same numbers, every refinement decision on the other triangles is the same, and
    the skipped triangle enters ``max_deviation_bound`` with A_t (below ``max_deviation``).
    ``deviation_samples`` counts the samples measured. The (u, v) grid's points outside every
    skipped footprint (coverage: holes, borders) are all measured as before.

    Shortcuts that change no figure: an edge node shared by two refined
    triangles is projected once (the same point and start give the same
    foot), and a refinement node whose warm-started projection converges
    below both its triangle's largest sample and the face's largest
    mesh sample (less 100 projection tolerances) keeps that run, without the
    global-minimum restarts (they could only bring it closer, or at most 10
    tolerances farther: it can raise neither maximum either way).
    A refinement node p(w) whose chord distance ``|S(x(w)) - p(w)|`` (x(w) the same barycentric
    combination of its triangle's corners' feet; plus 100 projection tolerances and the coordinates'
    rounding, `quality.deviation._chord_bound`) is below both its triangle's largest sample and the face's
    largest mesh sample is not projected at all: S(x(w)) is a point of the surface, so the node's
    distance, and the value the projection (a descent from x(w) itself) returns, is at most that and
    could raise neither (tolerance-only, refinement nodes projected: screw 14,022 -> 5,177, t20 18,660 ->
    1,812, featuretype 11,784 -> 3,077; the per-triangle
    maxima and densities are the same numbers, tests/quality/test_chord_prune.py).

    First-pass edge nodes left out by the same bound (`quality.deviation._first_pass_lazy`, faces of at
    least 128 triangles that do not take the skipping path above): a face's vertices and centroids are
    projected first; an edge node whose chord bound c(w) is below the face's largest vertex / centroid
    value, on triangles that pass the refinement's footprint test already, waits. Its value (and that of
    the footprint sample S(x(w)) at the same node) is at most c(w), so the face's maxima are the same;
    before the refinement decides anything, a triangle whose bound
    ``U_t + beta_t / ((1 - kappa_t U_t) k^2)`` with U_t = max(its values, its waiting nodes' c(w)) exceeds
    the maximum G over all faces has its waiting nodes projected (full search, restarts included:
    `_complete_first_pass`); the others have B_t <= G with their true D_t (the bound grows with D_t), so
    none is refined or raises ``max_deviation_bound``, and every figure is the same (proven, as far as
    the projections find the global foot; checked on the 34 shared runs, `benchmarks/measure_same.py`,
    and tests/quality/test_first_pass_lazy.py).
    Surface -> mesh, the first pass's (u, v) grid points are searched first within the face's largest
    values (`_closest_from`): the same distances bit for bit.
    """
    t0 = time.perf_counter()
    dev, states = _shell_deviation(mesh, shell, density=density, n_domain=n_domain, two_sided=True, tol_rel=1e-10,
                                   refine=refine, skip=True)
    # the centroids' feet, projected with the samples: `flipped_against_normal` does not project them again
    centroid_uv = {i: st.centroid_uv for i, st in enumerate(states) if st is not None and st.centroid_uv is not None}
    dev_bound = max((float(d.max_bound) for d in dev.faces if d is not None and np.isfinite(d.max_bound)),
                    default=float("nan"))
    dev_max = (float(dev.max_two_sided), float(dev.max_mesh_to_target), float(dev.max_target_to_mesh))
    skipped = {int(i) for i in skipped_faces}
    collapsed = _collapsed_faces(mesh, shell, set(dev.uncovered_faces.tolist()) - skipped, n_domain)
    if len(dev.uncovered_faces) and set(dev.uncovered_faces.tolist()) <= skipped | set(collapsed):
        covered = [d for d in dev.faces if d is not None]
        dev_max = tuple(max((float(getattr(d, k)) for d in covered), default=0.0)
                        for k in ("max_two_sided", "max_mesh_to_target", "max_target_to_mesh"))
        far = max(collapsed.values(), default=0.0)
        dev_max = (max(dev_max[0], far), dev_max[1], max(dev_max[2], far))
    e = mesh.edges()
    lengths = np.linalg.norm(mesh.vertices[e[:, 0]] - mesh.vertices[e[:, 1]], axis=1)
    tq = triangle_quality(mesh)
    topo = topology_report(mesh)
    flipped = flipped_against_normal(mesh, shell, reversed_faces=reversed_faces, centroid_uv=centroid_uv)
    return {
        "triangles": mesh.n_triangles,
        "vertices": mesh.n_vertices,
        "max_deviation": dev_max[0],
        "max_deviation_mesh_to_faces": dev_max[1],
        "max_deviation_faces_to_mesh": dev_max[2],
        "max_deviation_bound": max(dev_bound, dev_max[0]) if np.isfinite(dev_bound) else float("nan"),
        "deviation_samples": int(sum(d.n_mesh_samples + d.n_target_samples for d in dev.faces if d is not None)),
        "uncovered_faces": [int(i) for i in dev.uncovered_faces],
        "collapsed_faces": {str(i): d for i, d in sorted(collapsed.items())},
        "max_edge": float(lengths.max()),
        "min_angle_deg": float(tq.min_angle_deg),
        "p5_angle_deg": float(tq.p5_min_angle_deg),
        "boundary_edges": int(topo.n_boundary_edges),
        "nonmanifold_edges": int(topo.n_non_manifold_edges),
        "flipped": int(flipped),
        "orientation_consistent": bool(topo.is_consistently_oriented),
        "watertight": bool(topo.is_watertight),
        "components": int(topo.n_components),
        "seconds_measure": time.perf_counter() - t0,
    }


def _point_polyline_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance from each point `p` (k, 3) to the nearest of the segments a[j]-b[j] (s, 3)."""
    if not len(a):
        return np.full(len(p), np.inf)
    d = b - a
    dd = np.maximum(np.einsum("ij,ij->i", d, d), 1e-300)
    t = np.clip(np.einsum("kij,ij->ki", p[:, None, :] - a[None], d) / dd, 0.0, 1.0)
    q = a[None] + t[..., None] * d[None]
    return np.linalg.norm(p[:, None, :] - q, axis=2).min(axis=1)


def explained_nonmanifold_edges(mesh: TriMesh, face_meshes, tolerance: float) -> np.ndarray:
    """Mask over ``mesh.non_manifold_edges()``: those the model's own topology explains.

    A non-manifold edge (k > 2 triangles) is explained when the model's faces
    meet there as distinct sheets, in one of two ways:

    - k >= 3 faces meet along a curve: its k triangles belong to k distinct
      faces, and the trimmed boundary of each (its own mesh's boundary edges,
      `face_meshes`) runs along the edge: the edge's points at 1/4, 1/2 and 3/4
      lie within `tolerance` of it;
    - coincident faces (e.g. the interface face of two touching solids, stored
      once per solid): every face on the edge has exactly two triangles there,
      on either side of the edge (the edge runs once each way, normals within
      90 deg), i.e. the edge is a manifold interior edge of each face.

    Anything else (a face with two triangles next to one with one: a fold or a
    pinch of a face's own trims stitched onto a neighbour) is not explained.
    """
    nm = mesh.non_manifold_edges()
    out = np.zeros(len(nm), dtype=bool)
    if not len(nm) or mesh.face_id is None:
        return out
    edges, inv, counts = mesh.edges(), mesh.half_edge_edges(), mesh.edge_triangle_counts()
    nm_index = np.flatnonzero(counts > 2)
    he = mesh.half_edges()
    normals = mesh.triangle_normals()
    bounds: dict = {}
    for k, e in enumerate(nm_index):
        hes = np.flatnonzero(inv == e)
        tris = hes // 3
        fids = mesh.face_id[tris]
        uniq, per = np.unique(fids, return_counts=True)
        if np.all(per == 2):
            ok = True
            for f in uniq.tolist():
                h = hes[fids == f]
                t = tris[fids == f]
                ok &= bool(he[h[0], 0] == he[h[1], 1]) and float(normals[t[0]] @ normals[t[1]]) > 0.0
            out[k] = ok
            continue
        if not np.all(per == 1):
            continue
        a, b = mesh.vertices[edges[e, 0]], mesh.vertices[edges[e, 1]]
        pts = a + np.array([0.25, 0.5, 0.75])[:, None] * (b - a)
        ok = True
        for f in uniq.tolist():
            fm = face_meshes[f] if f < len(face_meshes) else None
            if fm is None:
                ok = False
                break
            if f not in bounds:
                be = fm.boundary_edges()
                bounds[f] = (fm.vertices[be[:, 0]], fm.vertices[be[:, 1]])
            if _point_polyline_distance(pts, *bounds[f]).max() > tolerance:
                ok = False
                break
        out[k] = ok
    return out


def measure_result(result, shell: Shell) -> dict:
    """`measure_mesh` of a `TessellationResult`'s mesh, plus the checks against its parameters.

    Adds ``within_tolerance`` and ``nonmanifold_edges_explained`` (non-manifold
    edges where three or more faces of the model meet, `explained_nonmanifold_edges`).
    What was measured (copies of the mesh's arrays, the shell, the reversed faces, the face meshes and
    the tolerance) is kept with the figures that depend on nothing else, for `figures_of_same_mesh`.
    """
    reversed_faces = result.report.get("faces_flipped", ())
    out = measure_mesh(result.mesh, shell, reversed_faces=reversed_faces,
                       skipped_faces=[f.index for f in result.failed_faces])
    out["within_tolerance"] = bool(out["max_deviation"] <= result.tolerance)
    out["nonmanifold_edges_explained"] = int(explained_nonmanifold_edges(result.mesh, result.face_meshes,
                                                                         result.tolerance).sum())
    _MEASURED[result.mesh] = _Measured(result.mesh, shell, reversed_faces, result.face_meshes, result.tolerance, out)
    return out


class _Measured:
    """What `measure_result` measured its figures on: copies of the mesh's arrays (so that a later change
    of the mesh's own arrays cannot pass for them), the shell and the face meshes (compared by identity),
    the reversed faces and the tolerance; and those figures."""

    def __init__(self, mesh: TriMesh, shell, reversed_faces, face_meshes, tolerance: float, figures: dict) -> None:
        self.vertices = np.array(mesh.vertices, dtype=np.float64, order="C")
        self.triangles = np.array(mesh.triangles, dtype=np.int64, order="C")
        self.face_id = None if mesh.face_id is None else np.array(mesh.face_id, dtype=np.int64)
        self.shell = shell
        self.reversed_faces = sorted(int(f) for f in reversed_faces)
        self.face_meshes = face_meshes
        self.tolerance = float(tolerance)
        self.figures = {k: figures[k] for k in ("nonmanifold_edges", "flipped", "nonmanifold_edges_explained")}


#: per mesh object measured by `measure_result` (weakly: the record goes with the mesh)
_MEASURED: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _same_bits(a: np.ndarray | None, b: np.ndarray | None) -> bool:
    """Same shape, dtype and bytes (float64: bit for bit, so -0.0 differs from 0.0); None only equals None."""
    if a is None or b is None:
        return a is None and b is None
    a, b = np.ascontiguousarray(a), np.ascontiguousarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def figures_of_same_mesh(back: TriMesh, mesh: TriMesh, shell: Shell, *, reversed_faces=(), face_meshes=None,
                         tolerance: float | None = None) -> dict:
    """The figures `measure_result` measured on `mesh` that hold for `back` too, because `back` is that mesh.

    `back` is typically the written file read back. Returns a dict with:

    - ``nonmanifold_edges`` when `back` holds exactly the vertices (float64, bit for bit) and the
      triangles (same order) that were measured: `topology_report` is a function of these alone;
    - also ``flipped`` and ``nonmanifold_edges_explained`` when, moreover, `back` holds the same
      ``face_id`` (not None), and `shell`, `reversed_faces`, `face_meshes` (the same objects) and
      `tolerance` are those of the measurement.

    Anything else gives an empty dict (or only ``nonmanifold_edges``): the caller measures `back` itself.
    The comparison is against copies taken when `mesh` was measured, not against `mesh`'s arrays now.
    ``flipped`` here took each centroid's foot from the deviation's samples (the (1/3, 1/3, 1/3) node of
    the triangle's grid, `measure_mesh`); `flipped_against_normal` on `back` without feet projects the
    centroids computed as the corners' mean: points that differ only by rounding. Measured on the 34
    shared runs (172,695 triangles): the feet differ in the last bits for ~70% of the triangles, the sign
    of no triangle's test differs, and the smallest |cos| between a triangle's normal and the surface
    normal at its foot is 0.23 (benchmarks/RESULTS.md, cli_measure.py): sampled, not proven.
    """
    rec = _MEASURED.get(mesh)
    if rec is None or not (_same_bits(back.vertices, rec.vertices) and _same_bits(back.triangles, rec.triangles)):
        return {}
    out = {"nonmanifold_edges": rec.figures["nonmanifold_edges"]}
    if (back.face_id is not None and _same_bits(back.face_id, rec.face_id) and rec.shell is shell
            and sorted(int(f) for f in reversed_faces) == rec.reversed_faces and face_meshes is rec.face_meshes
            and tolerance is not None and float(tolerance) == rec.tolerance):
        out["flipped"] = rec.figures["flipped"]
        out["nonmanifold_edges_explained"] = rec.figures["nonmanifold_edges_explained"]
    return out

"""Distance between a mesh and the surface (or face, shell, other mesh) it stands for.

Mesh -> surface: the mesh is sampled densely (`sample_triangles`) and every
sample projected onto the underlying surface (`geom.projection`); this is the
paper's absolute error sup |eta| (join-mesh-patches-whitney, Sec. II, eq. (1)),
a one-sided Hausdorff distance. Surface -> mesh: the face's trimmed (u, v)
region is sampled (`sample_face_domain`) and the exact distance of each
surface point to the mesh taken (`closest_points_on_mesh`); this side catches
missing coverage (holes, shrunk borders). The two-sided figure is the larger
maximum. RMS values are over the samples (uniform per triangle, not
area-weighted).
"""

from __future__ import annotations

import functools

from dataclasses import dataclass, field, fields, replace

import numpy as np

from ..errors import InputError, MeshError
from ..geom._seed_kernels import memo_points_kernel
from ..geom.nurbs import _clamp, _homogeneous, read_only
from ..geom.projection import _SETTLED_FRACTION, project_to_surface
from ..model import Shell, TriMesh
from ._results import ResultMixin
from ._kernels import uv_locate_kernel
from ._numeric import median
from . import closest_point as _cp
from .closest_point import _closest, _TriangleLocator, closest_points_on_mesh
from .interpolation_bound import domain_bound, span_bounds, triangle_bounds
from .sampling import (_inside_loops, as_face, distance_outside_face, loop_polygons, sample_face_domain,
                       sample_triangles)

__all__ = ["Deviation", "ShellDeviation", "surface_deviation", "shell_deviation", "mesh_deviation",
           "project_to_face", "refine_deviation", "max_curvature"]

#: densest barycentric grid (divisions per edge) `refine_deviation` samples a triangle with
MAX_DENSITY = 32
#: margin on the curvature sampled at a triangle's corners and centre, for the curvature between them
CURVATURE_MARGIN = 1.5
#: most points per face and direction of the surface -> mesh domain grid that follows the triangles
MAX_FOOTPRINT_GRID = 256
#: the surface -> mesh domain grid's spacing: the triangles' median (u, v) extent over this
FOOTPRINT_DIVISIONS = 2.5


@dataclass(frozen=True, eq=False)
class Deviation(ResultMixin):
    """One- and two-sided deviation between a mesh and a target (surface, face or mesh), model units.

    Attributes
    ----------
    max_mesh_to_target, rms_mesh_to_target : float
    where_mesh_to_target : (3,) float64
        Mesh sample with the largest distance.
    n_mesh_samples : int
    max_target_to_mesh, rms_target_to_mesh : float
        NaN when not computed (``two_sided=False``).
    where_target_to_mesh : (3,) float64
    n_target_samples : int
    max_two_sided : float
        max of both maxima (the one-sided max when the other side is not computed).
    n_not_converged : int
        Projections that did not meet the tolerance (their distance is an upper bound).
    n_outside_trim : int
        Mesh samples whose closest surface point lies outside the face's trim loops
        by more than `trim_tol_uv` (in (u, v)); -1 where not computed (the report's measurement).
    max_outside_trim_uv : float
        Largest (u, v) distance of such a foot from the trimmed region (0 when all inside; NaN where not
        computed).
    per_triangle_max : (m,) float64
        Largest mesh -> target distance among each triangle's samples (its corners and edges included).
    max_bound : float
        With adaptive sampling (``refine``): the curvature bound on the two-sided
        maximum between the samples (see `refine_deviation`); NaN otherwise.
    n_refined : int
        Triangles sampled again more densely by `refine_deviation`.
    """

    max_mesh_to_target: float
    rms_mesh_to_target: float
    where_mesh_to_target: np.ndarray
    n_mesh_samples: int
    max_target_to_mesh: float
    rms_target_to_mesh: float
    where_target_to_mesh: np.ndarray
    n_target_samples: int
    max_two_sided: float
    n_not_converged: int
    n_outside_trim: int
    max_outside_trim_uv: float
    per_triangle_max: np.ndarray
    max_bound: float = float("nan")
    n_refined: int = 0


def _stats(d: np.ndarray, pts: np.ndarray) -> tuple[float, float, np.ndarray]:
    if not len(d):
        return float("nan"), float("nan"), np.full(3, np.nan)
    k = int(np.argmax(d))
    return float(d[k]), float(np.sqrt(np.mean(d ** 2))), pts[k].copy()


#: the init fields `_replace` may set directly
_DEVIATION_FIELDS = frozenset(f.name for f in fields(Deviation))


def _replace(dev: Deviation, **changes) -> Deviation:
    """``dataclasses.replace(dev, **changes)`` for a `Deviation` (no ``__post_init__``, every field in the
    instance's ``__dict__``): the same object contents, without its per-field machinery (~5x cheaper;
    `refine_deviation` replaces every face's Deviation once or more). Anything else goes to
    ``dataclasses.replace`` (its checks and errors)."""
    if type(dev) is not Deviation or not changes.keys() <= _DEVIATION_FIELDS:
        return replace(dev, **changes)
    new = object.__new__(Deviation)
    d = new.__dict__
    d.update(dev.__dict__)
    d.update(changes)
    return new


def _check_mesh(mesh, name: str) -> None:
    if not isinstance(mesh, TriMesh):
        raise InputError(f"{name} needs a TriMesh; got {type(mesh).__name__}")
    if not mesh.n_triangles:
        raise MeshError(f"{name}: mesh has no triangles")


def project_to_face(points, face, *, tol_rel: float = 1e-10, uv0=None, skip_below=None):
    """Project points (n, 3) onto the surface of a face (or a NurbsSurface); returns `geom.projection.Projection`.

    ``uv0`` (n, 2), optional: warm-start parameters; ``skip_below`` (n,), optional, with ``uv0``: see
    `geom.projection.project_to_surface`.
    """
    s = as_face(face).surface
    return project_to_surface(np.asarray(points, dtype=np.float64).reshape(-1, 3), s.degree_u, s.degree_v,
                              s.knots_u, s.knots_v, s.control_points, s.weights, tol_rel=tol_rel, uv0=uv0,
                              compiled=True, skip_below=skip_below)


def surface_deviation(mesh: TriMesh, target, *, density: int = 4, n_domain: int = 64, two_sided: bool = True,
                      tol_rel: float = 1e-10, trim_tol_uv: float | None = None,
                      refine: float | None = None) -> Deviation:
    """Deviation of a mesh from a NURBS surface or trimmed face (max and RMS, one- and two-sided).

    Parameters
    ----------
    mesh : TriMesh
    target : NurbsSurface or TrimmedFace
    density : int
        Barycentric grid divisions per triangle edge for the mesh samples.
    n_domain : int
        Grid points per (u, v) direction for the surface samples.
    two_sided : bool
        Also measure surface -> mesh.
    tol_rel : float
        Projection tolerance, relative to the control net's diagonal.
    trim_tol_uv : float or None
        Feet farther than this outside the trim loops (parameter units) are
        counted in `n_outside_trim`; default 1e-3 of the (u, v) box diagonal
        of the outer loop (a chord of a curved border projects slightly outside).
    refine : float or None
        Adaptive sampling (`refine_deviation`): every triangle is also sampled
        on the surface over its own (u, v) footprint, the domain grid follows the
        triangles' (u, v) size, and triangles whose curvature bound could hide a
        value above the maximum by more than ``refine`` x the maximum get denser
        barycentric grids until none can. None: the fixed grids only.

    Returns
    -------
    Deviation

    Raises
    ------
    InputError
        Wrong types or options; MeshError for a mesh without triangles.

    Notes
    -----
    Mesh samples are projected onto the whole underlying surface; samples
    whose foot falls outside the trim loops are counted in `n_outside_trim`.
    When the mesh carries per-vertex ``uv``, the projection of each sample
    starts from the barycentric interpolation of its triangle's ``uv``
    (a start that fails is redone from the seeds, so the result does not
    depend on the uv being right).
    The sampled maximum underestimates the true one by at most ``h^2 / (2 rho)``
    near a smooth interior maximum (h the grid's covering radius, rho the
    curvature radius of the distance level set), and by at most the Lipschitz
    bound ``h`` in general.

    References
    ----------
    join-mesh-patches-whitney.txt, Sec. II, eq. (1): absolute error sup |eta|.

    Examples
    --------
    >>> from trimsurf.model import NurbsSurface
    >>> plane = NurbsSurface(1, 1, [0, 0, 1, 1], [0, 0, 1, 1],
    ...                      [[[0, 0, 0], [0, 1, 0]], [[1, 0, 0], [1, 1, 0]]])
    >>> m = TriMesh([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [[0, 1, 2], [0, 2, 3]])
    >>> surface_deviation(m, plane).max_two_sided < 1e-12
    True
    """
    dev, state = _surface_deviation(mesh, target, density=density, n_domain=n_domain, two_sided=two_sided,
                                    tol_rel=tol_rel, trim_tol_uv=trim_tol_uv, adaptive=refine is not None)
    if refine is None:
        return dev
    return refine_deviation([dev], [state], rel=refine, tol_rel=tol_rel)[0][0]


class _Pre:
    """A face's first-pass samples with their vertices already projected (`_prepare_face`), and each
    triangle's a-priori bound (`interpolation_bound.triangle_bounds`)."""

    def __init__(self, samples, uv0, k0, vproj, apriori):
        self.samples, self.uv0, self.k0, self.vproj, self.apriori = samples, uv0, k0, vproj, apriori


def _prepare_face(mesh: TriMesh, face, density: int, tol_rel: float) -> _Pre:
    """The first pass's samples of a face's mesh (as `_surface_deviation` takes them), its vertex samples
    projected (the projection is point by point: the same feet as in one call with all samples), and the
    a-priori bound of every triangle between its points and the surface over its corners' feet."""
    samples = sample_triangles(mesh, density=density)
    uv0 = None if mesh.uv is None else np.einsum("kj,kjd->kd", samples.barycentric,
                                                  mesh.uv[mesh.triangles[samples.triangle]])
    k0 = np.flatnonzero(samples.kind == 0)
    vproj = project_to_face(samples.points[k0], face, tol_rel=tol_rel, uv0=None if uv0 is None else uv0[k0])
    vuv = np.full((mesh.n_vertices, 2), np.nan)
    vd = np.full(mesh.n_vertices, np.nan)
    vuv[samples.element[k0]] = vproj.uv
    vd[samples.element[k0]] = vproj.distance
    t = mesh.triangles
    apriori = triangle_bounds(_span_bounds(face.surface), vuv[t], vd[t])
    return _Pre(samples, uv0, k0, vproj, apriori)


def _span_bounds(surface):
    """`interpolation_bound.span_bounds`, kept per surface object while it lives (weakly)."""
    hit = _SPAN_BOUNDS.get(id(surface))
    if hit is not None and hit[0] is surface:
        return hit[1]
    sb = span_bounds(surface)
    if len(_SPAN_BOUNDS) >= 4096:
        _SPAN_BOUNDS.pop(next(iter(_SPAN_BOUNDS)))
    _SPAN_BOUNDS[id(surface)] = (surface, sb)
    return sb


_SPAN_BOUNDS: dict = {}


def _surface_deviation(mesh: TriMesh, target, *, density: int, n_domain: int, two_sided: bool, tol_rel: float,
                       trim_tol_uv: float | None, adaptive: bool = False, pre: _Pre | None = None,
                       skip_at: float = -np.inf, prune: bool = False, t2m_at: float | None = None):
    """`surface_deviation` and, with `adaptive`, the state `refine_deviation` continues from.

    `pre` (`_prepare_face`, with `adaptive` and `two_sided`): the samples and vertex feet computed
    already; then the triangles whose a-priori bound is at most `skip_at` are skipped (`_shell_deviation`):
    of their own samples only the centroid is projected (for `flipped_against_normal`), and the surface
    samples of the (u, v) grids that fall in their footprints are not measured.

    `prune` (`_shell_deviation` with ``skip``): without `pre`'s footprint hints, the (u, v) grids' exact
    distances to the mesh are searched by `_closest_from` with the larger of this face's largest mesh ->
    surface sample and `t2m_at` (the faces measured before: their largest surface -> mesh value) as the
    value to beat: the same distances, most found within that radius. The feet's distances outside the
    trim loops are not computed (``n_outside_trim`` -1, ``max_outside_trim_uv`` NaN): the report
    (`tessellate.measure.measure_mesh`, the only caller with ``skip``) has no such field.
    """
    _check_mesh(mesh, "surface_deviation")
    face = as_face(target)
    skip = None
    pending = None
    lazy = (prune and adaptive and two_sided and pre is None and density == 3 and mesh.uv is None
            and mesh.n_triangles >= LAZY_MIN_TRIANGLES)
    if lazy:
        samples, d, puv, n_conv, sel, pending = _first_pass_lazy(mesh, face, tol_rel)
        uv0 = None
    elif pre is None:
        samples = sample_triangles(mesh, density=density)
        # the mesh's per-vertex (u, v), interpolated at the samples, warm-starts the projection
        uv0 = None if mesh.uv is None else np.einsum("kj,kjd->kd", samples.barycentric,
                                                      mesh.uv[mesh.triangles[samples.triangle]])
        proj = project_to_face(samples.points, face, tol_rel=tol_rel, uv0=uv0)
        d = proj.distance
        puv = proj.uv
        n_conv = int(np.count_nonzero(~proj.converged))
        sel = None
    else:
        samples, uv0 = pre.samples, pre.uv0
        skip = pre.apriori <= skip_at
        sel = _kept_rows(mesh, samples, skip, density)
        rest = sel[samples.kind[sel] != 0]
        pr = project_to_face(samples.points[rest], face, tol_rel=tol_rel, uv0=None if uv0 is None else uv0[rest])
        n = len(samples.points)
        d = np.full(n, -np.inf)
        puv = np.full((n, 2), np.nan)
        d[pre.k0], puv[pre.k0] = pre.vproj.distance, pre.vproj.uv
        d[rest], puv[rest] = pr.distance, pr.uv
        n_conv = int(np.count_nonzero(~pre.vproj.converged) + np.count_nonzero(~pr.converged))
    if sel is None:
        mx, rms, where = _stats(d, samples.points)
        n_mesh = len(d)
    else:
        mx, rms, where = _stats(d[sel], samples.points[sel])
        n_mesh = len(sel)
    if prune:
        # the report's measurement (`_shell_deviation` with ``skip``) reports no trim figures: not computed
        outside, out_max = -1, float("nan")
    else:
        out_uv = distance_outside_face(face, puv if sel is None else puv[sel])
        if trim_tol_uv is None:
            (u0, u1), (v0, v1) = face.surface.domain
            box = np.array([[u0, v0], [u1, v1]]) if not face.loops else np.array(
                [loop_polygons(face, n_per_segment=8)[0].min(axis=0),
                 loop_polygons(face, n_per_segment=8)[0].max(axis=0)])
            trim_tol_uv = 1e-3 * float(np.linalg.norm(box[1] - box[0]))
        outside = int(np.count_nonzero(out_uv > trim_tol_uv))
        out_max = float(out_uv.max(initial=0.0))
    mx2, rms2, where2, n2 = float("nan"), float("nan"), np.full(3, np.nan), 0
    state = None
    vert_uv = None
    loc, fine = None, []
    if adaptive:
        vert_uv = np.full((mesh.n_vertices, 2), np.nan)
        k0 = np.flatnonzero(samples.kind == 0)
        vert_uv[samples.element[k0]] = puv[k0]
    if two_sided:
        uv = sample_face_domain(face, n=n_domain)
        if adaptive:
            uv = np.concatenate([uv, _footprint_grid(face, mesh, vert_uv, n_domain)])
        hint = None
        if skip is not None and skip.any():
            # each grid point's footprint triangle (its distance to it starts the exact search: the same
            # minimum); a surface point S(x(w)) in a skipped triangle's footprint lies within that
            # triangle's a-priori bound of the mesh point p(w): it cannot raise the surface -> mesh maximum
            hint, ins = _locate_uv(uv, vert_uv[mesh.triangles], skip)
            if ins.any():
                uv, hint = uv[~ins], hint[~ins]
        pts = _grid_points(face.surface, uv)
        if adaptive and np.all(np.isfinite(pts)):
            # the refinement measures to the same mesh again: its triangle search structure is kept
            loc = _TriangleLocator(mesh.vertices, mesh.triangles)
            if hint is None and prune:
                d2 = _closest_from(pts, loc, max(mx, t2m_at if t2m_at is not None else -np.inf))
            else:
                d2 = _closest(pts, loc, hint=hint).distance
        else:
            d2 = closest_points_on_mesh(pts, mesh).distance
        if adaptive:
            d2 = _drop_outside(face, uv, d2, cache=fine)
        mx2, rms2, where2 = _stats(d2, pts)
        n2 = len(pts)
    per_tri = samples.per_triangle_max(mesh, d)
    if adaptive:
        state = _FaceState(mesh, face, vert_uv, per_tri.copy(), np.full(mesh.n_triangles, int(density)),
                           two_sided, loop_polygons(face) if face.loops else None, loc, fine=fine)
        if skip is not None:
            state.skip, state.apriori = skip, pre.apriori
        state.prune = bool(prune)
        if pending is not None:
            state.pending = pending       # `_complete_first_pass`, from `refine_deviation`
        if density % 3 == 0:    # the centroid (1, 1, 1) / 3 is a node of the grid: kept for `flipped_against_normal`
            k = density // 3
            cen = np.flatnonzero((samples.kind == 2) & np.all(np.rint(samples.barycentric * density) == k, axis=1))
            if len(cen) == mesh.n_triangles:
                cuv = np.empty((mesh.n_triangles, 2))
                cuv[samples.element[cen]] = puv[cen]
                state.centroid_uv = cuv
    dev = Deviation(mx, rms, where, n_mesh, mx2, rms2, where2, n2,
                    float(np.nanmax([mx, mx2])), n_conv, outside, out_max, per_tri)
    return dev, state


def _grid_points(surface, uv: np.ndarray) -> np.ndarray:
    """``surface.evaluate(uv)`` bit for bit (the same clamping, the same kernel arithmetic) for (u, v) points
    that share parameter values, as the (u, v) grids of `sample_face_domain` do (32 x 32 or the footprint
    grid's, plus the loop polylines): `geom._seed_kernels.memo_points_kernel` computes each distinct u and v
    value's span and basis functions once instead of per point (U_Joint tolerance-only: 165K grid points,
    ~130 distinct values per direction and face). Anything but finite (n, 2) points goes to
    ``surface.evaluate`` (its checks and errors)."""
    uv = np.asarray(uv, dtype=np.float64)
    if uv.ndim != 2 or uv.shape[1] != 2 or not len(uv) or not np.all(np.isfinite(uv)):
        return surface.evaluate(uv)
    pu, pv, ku, kv, cp, w = surface._args()
    ku = np.asarray(ku, dtype=np.float64)
    kv = np.asarray(kv, dtype=np.float64)
    out = np.empty((len(uv), 3))
    memo_points_kernel(int(pu), int(pv), read_only(ku), read_only(kv), np.ascontiguousarray(_homogeneous(cp, w)),
                       w is not None, np.ascontiguousarray(_clamp(uv[:, 0], ku, pu)),
                       np.ascontiguousarray(_clamp(uv[:, 1], kv, pv)), out)
    return out


#: faces with at least this many triangles take `_first_pass_lazy` (`_shell_deviation` with ``skip``): below,
#: its second projection call costs more than the projections it saves
LAZY_MIN_TRIANGLES = 128


def _first_pass_lazy(mesh: TriMesh, face, tol_rel: float):
    """The first pass's mesh samples (density 3) with the edge nodes that provably cannot matter left for
    later: (samples, d, puv, n_not_converged, measured rows, pending) as `_surface_deviation` uses them.

    The vertices and centroids are projected first (every centroid's foot serves
    `flipped_against_normal`). Each edge node p(w) then has its chord bound c(w) = |S(x(w)) - p(w)| +
    slack (`_chord_bound`; x(w) the same combination of its edge's corners' feet): S(x(w)) is a surface
    point, so the node's distance to the surface is at most c(w), and so is the distance of the surface
    point S(x(w)) to the mesh (the refinement's footprint sample at the same node). A node is not
    projected now (it is *pending*) when c(w) is below the largest vertex or centroid value of the face
    M1 and every triangle on its edge passes the refinement's footprint test with the values measured
    so far (``|S(centre) - centroid| <= 2 R + 2 L_t``, `refine_deviation`; it then passes with any
    larger value). Everything else is projected as before (the full search, restarts included), and
    every projection is point by point, so the measured values are those of projecting all samples.

    What this leaves unchanged: the face's largest mesh sample (a pending node is below M1, a value the
    face reaches), so every maximum, skipping threshold and face order of `_shell_deviation`; every
    triangle's footprint test (so the same footprint samples and curvature bounds). What waits: a
    triangle's largest sample D_t, which `_complete_first_pass` settles once the curvature bounds and
    the maximum G over all faces are known, before any refinement decision.

    One case could differ from projecting every node, as in `_chord_bound`: a projection whose global
    search misses the nearest foot returns more than the true distance, possibly more than c(w); a
    pending node then keeps the lower (truer) value (not seen on the 34 shared runs).
    """
    samples = sample_triangles(mesh, density=3)
    kind = samples.kind
    n = len(samples.points)
    first = np.flatnonzero(kind != 1)               # vertices and centroids (density 3: the interior node)
    p1 = project_to_face(samples.points[first], face, tol_rel=tol_rel)
    d = np.full(n, -np.inf)
    puv = np.full((n, 2), np.nan)
    d[first], puv[first] = p1.distance, p1.uv
    n_conv = int(np.count_nonzero(~p1.converged))
    e1 = np.flatnonzero(kind == 1)
    m1 = float(np.max(p1.distance)) if len(first) else -np.inf
    pend = np.zeros(0, dtype=np.int64)
    if len(e1) and np.isfinite(m1):
        k0 = first[kind[first] == 0]
        vert_uv = np.full((mesh.n_vertices, 2), np.nan)
        vert_uv[samples.element[k0]] = puv[k0]
        t = mesh.triangles
        cuv = vert_uv[t]
        uv_e = np.einsum("kj,kjd->kd", samples.barycentric[e1], cuv[samples.triangle[e1]])
        c = _chord_bound(face.surface, uv_e, samples.points[e1], tol_rel)
        # the refinement's footprint test (`refine_deviation`: corners' feet finite, the (u, v) centre's
        # surface point within 2 R + 2 D_t of the centroid), passed with the values so far L_t <= D_t
        s_i, t_i = samples.incidence(mesh)
        lo_t = np.full(len(t), -np.inf)
        np.maximum.at(lo_t, t_i, d[s_i])             # `per_triangle_max` of the values so far
        p = mesh.vertices[t]
        good = np.all(np.isfinite(cuv.reshape(len(t), -1)), axis=1)
        if good.any():
            r = _enclosing_radius(p[good])
            c3 = face.surface.evaluate(cuv[good].mean(axis=1))
            good[good] = np.linalg.norm(c3 - p[good].mean(axis=1), axis=1) <= (
                (2.0 * r + 2.0 * np.maximum(lo_t[good], 0.0)) * (1.0 - 1e-12))
        node_ok = np.ones(n, dtype=bool)
        node_ok[s_i[~good[t_i]]] = False
        low = (c < m1) & node_ok[e1]
        pend = e1[low]
        c_pend = c[low]
        e1 = e1[~low]
    if len(e1):
        p2 = project_to_face(samples.points[e1], face, tol_rel=tol_rel)
        d[e1], puv[e1] = p2.distance, p2.uv
        n_conv += int(np.count_nonzero(~p2.converged))
    if not len(pend):
        return samples, d, puv, n_conv, None, None
    keep = np.ones(n, dtype=bool)
    keep[pend] = False
    pos = np.full(n, -1, dtype=np.int64)
    pos[pend] = np.arange(len(pend))
    hit = pos[s_i] >= 0
    pending = (samples.points[pend], c_pend, pos[s_i][hit], t_i[hit])
    return samples, d, puv, n_conv, np.flatnonzero(keep), pending


def _complete_first_pass(devs: list, states: list, info: dict, live: list, tol_rel: float) -> None:
    """Project the pending first-pass nodes (`_first_pass_lazy`) of the face states `live` that could matter,
    once `refine_deviation` has the curvature bounds (beta_t, kappa_t in ``info[i]``) and the footprint
    samples.

    With U_t = max(the triangle's largest value so far, the chord bounds of its pending nodes) >= D_t
    (its largest value with every node projected; the footprint samples are in the first term), a
    triangle whose bound ``U_t + beta_t / (max(1 - kappa_t U_t, 0.5) k^2)`` is at most G (the largest
    sample over all faces now) has B_t <= G with the true D_t as well (the bound grows with D_t): it is
    never refined (the refinement asks for B_t > (1 + rel) G', G' >= G), and its bound stays below the
    reported one (``max(B_t, G)`` over all triangles). Its pending nodes stay unmeasured; its B_t from
    the values it has is lower still. Every other triangle's pending nodes are projected now (full
    search, the values they would have had), so its D_t, refinement and bound are as without pending
    nodes. No maximum changes: a pending node is below its face's largest mesh sample.
    """
    todo = [i for i in live if getattr(states[i], "pending", None) is not None]
    if not todo:
        return
    g = max(float(np.nanmax([dv.max_two_sided, 0.0])) for dv in devs if dv is not None)
    for i in todo:
        _complete_face(devs, states[i], info[i], i, g, tol_rel)


def _complete_face(devs: list, st, info_i: tuple, i: int, g: float, tol_rel: float) -> None:
    """`_complete_first_pass` for one face state, with G = `g`."""
    pts, c, s_rows, t_rows = st.pending
    st.pending = None
    beta, _, kap = info_i[:3]
    u = st.tri_max.copy()
    np.maximum.at(u, t_rows, c[s_rows])
    with np.errstate(invalid="ignore"):
        b = u + beta / np.maximum(1.0 - kap * u, 0.5) / st.density ** 2
    need = ~(b <= g)
    node_need = np.zeros(len(pts), dtype=bool)
    np.logical_or.at(node_need, s_rows, need[t_rows])
    idx = np.flatnonzero(node_need)
    if not len(idx):
        return
    pr = project_to_face(pts[idx], st.face, tol_rel=tol_rel)
    val = np.full(len(pts), -np.inf)
    val[idx] = pr.distance
    np.maximum.at(st.tri_max, t_rows, val[s_rows])
    dev = devs[i]
    j = int(np.argmax(pr.distance))
    mx, where = dev.max_mesh_to_target, dev.where_mesh_to_target
    if pr.distance[j] > mx:         # not expected: a pending node is below the face's largest value
        mx, where = float(pr.distance[j]), pts[idx[j]].copy()
    devs[i] = _replace(dev, max_mesh_to_target=mx, where_mesh_to_target=where,
                      n_mesh_samples=dev.n_mesh_samples + len(idx),
                      n_not_converged=dev.n_not_converged + int(np.count_nonzero(~pr.converged)),
                      max_two_sided=float(np.nanmax([mx, dev.max_target_to_mesh])))


def _closest_from(pts: np.ndarray, loc, at: float) -> np.ndarray:
    """Exact distances of the points `pts` (n, 3) to `loc`'s triangles (`closest_point._TriangleLocator`),
    bit for bit those of ``closest_point._closest(pts, loc).distance``, searched first within `at`.

    `_kernels.grid_closest_kernel` keeps a bound it is given and replaces it only by a strictly nearer
    triangle; it stops once every triangle with a point nearer than its current best has been tried. Given
    the bound `at` (> 0) for every point, it therefore returns, for a point whose distance d* to the
    mesh is below `at`, the same minimum d* over the same triangle-point values (`_kernels._tri_closest`)
    as a search from infinity, having tried only triangles nearer than `at`; for a point with
    d* >= `at` it returns `at` itself, and that point is searched again from infinity. The result does
    not depend on `at` (any positive value gives the same distances; NaN, inf or <= 0: one plain search);
    a value about the distances' maximum makes most points' searches short.
    """
    n = len(pts)
    q = np.ascontiguousarray(pts, dtype=np.float64)
    lo, hi, origin, h, dims, start, items = loc.grid
    if not (np.isfinite(at) and at > 0.0) or n == 0:
        return _closest(q, loc).distance
    best_d = np.full(n, float(at))
    best_t = np.zeros(n, dtype=np.int64)
    best_p = np.zeros((n, 3))
    best_w = np.zeros((n, 3))
    # through the module (one kernel, timed where benchmarks wrap it)
    _cp.grid_closest_kernel(q, loc.a, loc.b, loc.c, lo, hi, origin, h, dims, start, items, best_d, best_t, best_p,
                            best_w)
    redo = np.flatnonzero(~(best_d < at))
    if len(redo):
        best_d[redo] = _closest(np.ascontiguousarray(q[redo]), loc).distance
    return best_d


def _kept_rows(mesh: TriMesh, samples, skip: np.ndarray, density: int) -> np.ndarray:
    """The first-pass sample rows measured when the triangles `skip` are skipped: every vertex, the edge
    samples of every edge with a kept triangle on it, the interior samples of kept triangles, and the
    centroid of every skipped triangle (its foot serves `flipped_against_normal`)."""
    kind, el = samples.kind, samples.element
    keep_tri = ~skip
    inv = mesh.half_edge_edges()
    edge_kept = np.zeros(int(inv.max(initial=-1)) + 1, dtype=bool)
    np.logical_or.at(edge_kept, inv, np.repeat(keep_tri, 3))
    rows = (kind == 0)
    k1 = kind == 1
    rows[k1] = edge_kept[el[k1]]
    k2 = kind == 2
    rows[k2] = keep_tri[el[k2]]
    if density % 3 == 0:
        k = density // 3
        cen = k2 & np.all(np.rint(samples.barycentric * density) == k, axis=1)
        rows |= cen
    return np.flatnonzero(rows)


def _locate_uv(uv: np.ndarray, tri: np.ndarray, skip: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """For (u, v) points uv (n, 2) and triangles tri (m, 3, 2): a triangle holding each point (closed; -1
    none) and whether a triangle with `skip` holds it (`_kernels.uv_locate_kernel`). Points are binned in
    a uniform grid about the triangles' median box size."""
    n, m = len(uv), len(tri)
    hint = np.full(n, -1, dtype=np.int64)
    ins = np.zeros(n, dtype=bool)
    fin_t = np.all(np.isfinite(tri.reshape(m, -1)), axis=1) if m else np.zeros(0, dtype=bool)
    fin = np.all(np.isfinite(uv), axis=1) if n else np.zeros(0, dtype=bool)
    if not fin_t.any() or not fin.any():
        return hint, ins
    lo_t, hi_t = tri[fin_t].min(axis=1), tri[fin_t].max(axis=1)
    lo = np.minimum(lo_t.min(axis=0), uv[fin].min(axis=0))
    hi = np.maximum(hi_t.max(axis=0), uv[fin].max(axis=0))
    span = np.maximum(hi - lo, 1e-300)
    ext = np.maximum(np.median(hi_t - lo_t, axis=0), span * 2.0 ** -11)
    dims = np.minimum(np.floor(span / ext).astype(np.int64) + 1, 2048)
    h = span / dims
    cell = np.clip(np.floor((np.where(fin[:, None], uv, lo) - lo) / h).astype(np.int64), 0, dims - 1)
    cid = np.where(fin, cell[:, 0] * dims[1] + cell[:, 1], int(dims[0] * dims[1]))
    order = np.argsort(cid, kind="stable")
    start = np.searchsorted(cid[order], np.arange(int(dims[0] * dims[1]) + 1))
    sk = np.zeros(m, dtype=bool) if skip is None else np.ascontiguousarray(skip, dtype=bool)
    uv_locate_kernel(np.ascontiguousarray(uv, dtype=np.float64), order.astype(np.int64), start.astype(np.int64),
                     lo.astype(np.float64), h.astype(np.float64), dims.astype(np.int64),
                     np.ascontiguousarray(tri, dtype=np.float64), sk, hint, ins)
    return hint, ins


@dataclass(frozen=True, eq=False)
class ShellDeviation(ResultMixin):
    """Per-face and overall deviation of a mesh with ``face_id`` from a shell.

    Attributes
    ----------
    faces : tuple of Deviation or None
        One per shell face; None for a face with no triangles.
    uncovered_faces : (k,) int64
        Faces without triangles.
    max_mesh_to_target, rms_mesh_to_target, max_target_to_mesh, rms_target_to_mesh, max_two_sided : float
        Over all faces (RMS over all samples).
    worst_face : int
    """

    faces: tuple
    uncovered_faces: np.ndarray
    max_mesh_to_target: float
    rms_mesh_to_target: float
    max_target_to_mesh: float
    rms_target_to_mesh: float
    max_two_sided: float
    worst_face: int

    def as_dict(self, *, arrays: bool = False) -> dict:
        out = super().as_dict(arrays=arrays)
        out["faces"] = [None if f is None else f.as_dict(arrays=arrays) for f in self.faces]
        return out


def _pooled_rms(rms: list[float], n: list[int]) -> float:
    pairs = [(r, k) for r, k in zip(rms, n) if k and np.isfinite(r)]
    if not pairs:
        return float("nan")
    return float(np.sqrt(sum(r * r * k for r, k in pairs) / sum(k for _, k in pairs)))


def shell_deviation(mesh: TriMesh, shell: Shell, *, density: int = 4, n_domain: int = 64, two_sided: bool = True,
                    tol_rel: float = 1e-10, refine: float | None = None) -> ShellDeviation:
    """Deviation of a mesh from each face of a shell, by the mesh's ``face_id``, and overall.

    Parameters are those of `surface_deviation`; surface -> mesh is measured
    against the triangles of the same face. With `refine`, triangles are
    resampled (`refine_deviation`) until none of any face could hide more than
    ``(1 + refine)`` x the overall maximum; per-face figures of faces far
    below the maximum stay at the coarser sampling.

    Raises
    ------
    InputError
        Not a Shell; MeshError when the mesh has no face_id or a face_id out of range.
    """
    return _shell_deviation(mesh, shell, density=density, n_domain=n_domain, two_sided=two_sided, tol_rel=tol_rel,
                            refine=refine)[0]


def _shell_deviation(mesh: TriMesh, shell: Shell, *, density: int, n_domain: int, two_sided: bool, tol_rel: float,
                     refine: float | None, skip: bool = False) -> tuple[ShellDeviation, list]:
    """`shell_deviation` and the per-face states of the refinement (None per face without it).

    `skip` (with `refine` and `two_sided`): triangles that cannot change the overall maxima are not
    sampled. Each face's vertices are projected first and every triangle gets its a-priori bound A_t
    (`interpolation_bound`: proven, from the control net, on the distance between its points and the
    surface over its corners' feet, both ways). The faces are measured in decreasing order of their
    largest A_t; a triangle with A_t at most T = min(largest mesh -> face sample, largest face -> mesh
    sample) over the faces measured before it is skipped: none of its samples, at any density, could
    exceed T, a value both overall maxima reach, so ``max_mesh_to_target``, ``max_target_to_mesh`` and
    ``max_two_sided`` over the shell are the same numbers, and so is every refinement decision on the
    other triangles (their own samples, bounds and the running maximum are unchanged). Skipped
    triangles enter the bound with A_t (<= T). Per-face figures of faces with skipped triangles may be
    lower than without skipping (never above); the sample counts and RMS values cover the measured
    samples only. Faces of at least `LAZY_MIN_TRIANGLES` triangles measured without that skipping take
    `_first_pass_lazy` (edge nodes below their face's maximum by their chord bound wait, and
    `_complete_first_pass`, from `refine_deviation`, projects those that could matter): the same maxima,
    refinement decisions and bound.
    """
    _check_mesh(mesh, "shell_deviation")
    if not isinstance(shell, Shell):
        raise InputError(f"shell_deviation needs a Shell; got {type(shell).__name__}")
    if mesh.face_id is None:
        raise MeshError("shell_deviation: mesh has no face_id (which face each triangle came from)")
    n_faces = len(shell.faces)
    if mesh.face_id.min() < 0 or mesh.face_id.max() >= n_faces:
        raise MeshError(f"shell_deviation: face_id must lie in [0, {n_faces}); got "
                        f"[{int(mesh.face_id.min())}, {int(mesh.face_id.max())}]")
    results: list[Deviation | None] = [None] * n_faces
    states: list = [None] * n_faces
    order = np.argsort(mesh.face_id, kind="stable")
    bounds = np.searchsorted(mesh.face_id[order], np.arange(n_faces + 1))
    subs = _face_submeshes(mesh, order, bounds)
    faces_order = sorted(subs)
    flat = {}
    if skip and refine is not None and two_sided:
        # each face's bound on the interpolation term E over its whole domain: the faces where it is
        # largest are measured first, and a face whose E is at most the maxima so far takes the skipping
        # path (its vertices projected first, then every triangle's own A_t decides)
        flat = {i: domain_bound(_span_bounds(as_face(shell.faces[i]).surface)) for i in faces_order}
        faces_order = sorted(faces_order, key=lambda i: (-flat[i], i))
    m1 = m2 = -np.inf
    for i in faces_order:
        t_skip = min(m1, m2)
        pre = None
        if i in flat and flat[i] <= t_skip:
            pre = _prepare_face(subs[i], as_face(shell.faces[i]), density, tol_rel)
        dev, st = _surface_deviation(subs[i], shell.faces[i], density=density, n_domain=n_domain,
                                     two_sided=two_sided, tol_rel=tol_rel, trim_tol_uv=None,
                                     adaptive=refine is not None, pre=pre, skip_at=t_skip, prune=bool(flat),
                                     t2m_at=m2 if flat else None)
        if np.isfinite(dev.max_mesh_to_target):
            m1 = max(m1, float(dev.max_mesh_to_target))
        if np.isfinite(dev.max_target_to_mesh):
            m2 = max(m2, float(dev.max_target_to_mesh))
        results[i] = dev
        states[i] = st
    if refine is not None:
        results = refine_deviation(results, states, rel=refine, tol_rel=tol_rel)[0]
    done = [r for r in results if r is not None]
    uncovered = np.array([i for i, r in enumerate(results) if r is None], dtype=np.int64)
    two = [r.max_two_sided for r in done]
    max_t2m = max((r.max_target_to_mesh for r in done), default=float("nan"))
    if len(uncovered) and two_sided:
        max_t2m = float("inf")
    worst = int(np.argmax([-1.0 if r is None else r.max_two_sided for r in results]))
    return ShellDeviation(
        faces=tuple(results), uncovered_faces=uncovered,
        max_mesh_to_target=max((r.max_mesh_to_target for r in done), default=float("nan")),
        rms_mesh_to_target=_pooled_rms([r.rms_mesh_to_target for r in done], [r.n_mesh_samples for r in done]),
        max_target_to_mesh=float(max_t2m),
        rms_target_to_mesh=_pooled_rms([r.rms_target_to_mesh for r in done], [r.n_target_samples for r in done]),
        max_two_sided=float(max(two + ([float("inf")] if len(uncovered) and two_sided else []), default=np.nan)),
        worst_face=worst), states


def _face_submeshes(mesh: TriMesh, order: np.ndarray, bounds: np.ndarray) -> dict:
    """``{i: mesh.submesh(order[bounds[i]:bounds[i + 1]])}`` for every face i with triangles (`order` the
    triangles sorted by face, stable: each face's rows ascending), each submesh's edge topology
    (`TriMesh`'s cached ``_half_edges`` and ``_edge_index``) filled in as well: the same arrays, from one
    ``np.unique`` over all faces instead of two per face (U_Joint: 133 faces of ~16 triangles).

    Per face f with n_f vertices, `TriMesh.submesh` numbers the used vertices in increasing order, and
    ``_edge_index`` sorts its undirected edges by the key ``min * n_f + max`` (< n_f^2). Over all faces
    the key (face, vertex) = ``f * n + vertex`` and the edge key ``offset_f + min * n_f + max`` (offset_f
    the sum of n_g^2 over g < f) sort face by face, each face's entries in its own order: each face's
    slice of the global unique (its values less the face's offset, its inverse less the face's first
    index) is that face's own unique (tests/quality/test_face_submeshes.py)."""
    faces = [i for i in range(len(bounds) - 1) if bounds[i + 1] > bounds[i]]
    if not faces:
        return {}
    nv = max(mesh.n_vertices, 1)
    fid = np.repeat(np.arange(len(bounds) - 1, dtype=np.int64), np.diff(bounds))
    tris = mesh.triangles[order]
    vkey = (fid[:, None] * nv + tris).ravel()
    ukey, vinv = np.unique(vkey, return_inverse=True)
    vinv = vinv.ravel()
    vface = ukey // nv
    vstart = np.searchsorted(vface, np.arange(len(bounds)))             # each face's first used vertex
    local = (vinv - vstart[fid.repeat(3)]).reshape(-1, 3)                  # the submeshes' triangles, stacked
    n_f = np.maximum(np.diff(vstart), 1)                                   # max(n_vertices, 1) per face
    he = np.stack([local, np.roll(local, -1, axis=1)], axis=2).reshape(-1, 2)
    off = _key_offsets(n_f)
    hf = fid.repeat(3)
    ekey = off[hf] + np.minimum(he[:, 0], he[:, 1]) * n_f[hf] + np.maximum(he[:, 0], he[:, 1])
    keys, inverse, counts = np.unique(ekey, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    estart = np.searchsorted(keys, off)
    subs = {}
    for i in faces:
        a, b = int(bounds[i]), int(bounds[i + 1])
        rows = order[a:b]
        used = ukey[vstart[i]:vstart[i + 1]] - i * nv
        sub = TriMesh(mesh.vertices[used], local[a:b], uv=None if mesh.uv is None else mesh.uv[used],
                      face_id=None if mesh.face_id is None else mesh.face_id[rows])
        n, e0, e1 = int(n_f[i]), int(estart[i]), int(estart[i + 1])
        k = keys[e0:e1] - off[i]
        h = he[3 * a:3 * b]
        h.setflags(write=False)
        idx = (np.column_stack([k // n, k % n]).astype(np.int64), inverse[3 * a:3 * b] - e0,
               counts[e0:e1].astype(np.int64))
        for arr in idx:
            arr.setflags(write=False)
        sub.__dict__["_half_edges"] = h          # `functools.cached_property` values: the instance's dict
        sub.__dict__["_edge_index"] = idx
        subs[i] = sub
    return subs


def _key_offsets(n_f: np.ndarray) -> np.ndarray:
    """Each face's edge-key offset in `_face_submeshes`: the sum of n_g^2 over the faces g before it (and the
    total last)."""
    return np.concatenate([[0], np.cumsum(n_f * n_f)])


def mesh_deviation(mesh: TriMesh, other: TriMesh, *, density: int = 4) -> Deviation:
    """Two-sided Hausdorff distance between two meshes by sampling (max and RMS).

    Both meshes are sampled with `sample_triangles` and the exact distance of
    each sample to the other mesh is taken. The sampled maximum underestimates
    the Hausdorff distance by at most the covering radius of the grid.

    Parameters
    ----------
    mesh, other : TriMesh
    density : int

    Returns
    -------
    Deviation
        "target" is `other`; `n_not_converged` and `n_outside_trim` are 0.

    Examples
    --------
    >>> a = TriMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    >>> b = TriMesh([[0, 0, 0.5], [1, 0, 0.5], [0, 1, 0.5]], [[0, 1, 2]])
    >>> mesh_deviation(a, b).max_two_sided
    0.5
    """
    _check_mesh(mesh, "mesh_deviation")
    _check_mesh(other, "mesh_deviation")
    sa = sample_triangles(mesh, density=density)
    sb = sample_triangles(other, density=density)
    da = closest_points_on_mesh(sa.points, other).distance
    db = closest_points_on_mesh(sb.points, mesh).distance
    mx, rms, where = _stats(da, sa.points)
    mx2, rms2, where2 = _stats(db, sb.points)
    return Deviation(mx, rms, where, len(da), mx2, rms2, where2, len(db), max(mx, mx2), 0, 0, 0.0,
                     sa.per_triangle_max(mesh, da))


@dataclass(eq=False)
class _FaceState:
    mesh: TriMesh
    face: object
    vert_uv: np.ndarray         # (n, 2) foot of each vertex on the surface (NaN: unused vertex)
    tri_max: np.ndarray         # (m,) largest two-sided sample value over each triangle
    density: np.ndarray         # (m,) barycentric divisions the triangle was sampled with
    two_sided: bool
    polys: list | None          # the trim loops as polygons in (u, v) (None: untrimmed)
    loc: object = None          # the mesh's triangle search structure (`closest_point._TriangleLocator`)
    centroid_uv: np.ndarray | None = None   # (m, 2) feet of the triangles' centroids (None: not sampled)
    skip: np.ndarray | None = None          # (m,) triangles skipped (a-priori bound below the maxima) or None
    apriori: np.ndarray | None = None       # (m,) their a-priori bounds (`interpolation_bound`) or None
    fine: list = field(default_factory=list)    # the fine trim polygons of `_drop_outside`, once computed
    prune: bool = False         # refinement nodes below their thresholds by their chord bound are not projected


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.cross(a, b)`` of (n, 3) rows, the same operations (a1 b2 - a2 b1, ...) without its axis handling."""
    out = np.empty(a.shape)
    a0, a1, a2 = a[:, 0], a[:, 1], a[:, 2]
    b0, b1, b2 = b[:, 0], b[:, 1], b[:, 2]
    np.subtract(a1 * b2, a2 * b1, out=out[:, 0])
    np.subtract(a2 * b0, a0 * b2, out=out[:, 1])
    np.subtract(a0 * b1, a1 * b0, out=out[:, 2])
    return out


def _second_forms(surface, uv) -> tuple[np.ndarray, np.ndarray]:
    """The shape operator as a 3D quadratic form W (n, 3, 3) (``e.W.e`` = normal curvature x |e|^2 for a
    tangent vector e) and the largest absolute principal curvature (n,), at (u, v) points (n, 2); NaN
    where the surface is singular."""
    uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
    d = surface.derivatives(uv, 2)
    w, kmax, det = _forms(d[1, 0], d[0, 1], d[2, 0], d[1, 1], d[0, 2])
    _drop_singular(w, kmax, det)
    return w, kmax


def _forms(su, sv, suu, suv, svv) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """`_second_forms`'s W, kmax and det = |Su x Sv|^2 from the derivatives ((n, 3) C-contiguous each), row by
    row (each row's numbers do not depend on the others), before `_drop_singular`."""
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        n = _cross(su, sv)
        n = n / np.linalg.norm(n, axis=1, keepdims=True)
        e, f, g = (np.einsum("ij,ij->i", a, b) for a, b in ((su, su), (su, sv), (sv, sv)))
        l_, m_, n_ = (np.einsum("ij,ij->i", a, n) for a in (suu, suv, svv))
        det = e * g - f * f
        k = (l_ * n_ - m_ * m_) / det
        h = (e * n_ - 2 * f * m_ + g * l_) / (2 * det)
        kmax = np.abs(h) + np.sqrt(np.maximum(h * h - k, 0.0))
        # dual basis: J+ = G^-1 [Su; Sv] (2 x 3), W = J+^T II J+
        gi = np.stack([np.stack([g, -f], -1), np.stack([-f, e], -1)], -2) / det[:, None, None]
        jp = gi @ np.stack([su, sv], 1)
        ii = np.stack([np.stack([l_, m_], -1), np.stack([m_, n_], -1)], -2)
        w = np.swapaxes(jp, 1, 2) @ ii @ jp
    return w, kmax, det


def _drop_singular(w: np.ndarray, kmax: np.ndarray, det: np.ndarray) -> None:
    """NaN in `w` and `kmax` (in place) where the forms are rounding noise: near a pole (Su x Sv -> 0, e.g.
    v = 1e-17 on a fuselage nose: curvature 1e14) no value where |Su x Sv|^2 is below 1e-8 of its median over
    the points given."""
    fin = np.isfinite(det) & (det > 0)
    ref = median(det[fin]) if fin.any() else 0.0
    bad = ~np.isfinite(kmax) | ~np.all(np.isfinite(w.reshape(len(w), -1)), axis=1) | ~(det > 1e-8 * ref)
    kmax[bad] = np.nan
    w[bad] = np.nan


def _second_forms_two(surface, uv_a: np.ndarray, uv_b: np.ndarray):
    """``_second_forms(surface, uv_a)`` and ``_second_forms(surface, uv_b)`` (each with its own median in
    `_drop_singular`) from one evaluation of the derivatives for both, in the projection's compiled
    evaluator (`geom.projection._surface_eval_compiled`: `surface_derivatives`' numbers, bit for bit;
    tests/geom/test_projection.py)."""
    from ..geom.nurbs import _homogeneous, read_only
    from ..geom.projection import _surface_eval_compiled

    na = len(uv_a)
    uv = np.concatenate([uv_a, uv_b]).astype(np.float64, copy=False)
    surf = (int(surface.degree_u), int(surface.degree_v), read_only(surface.knots_u), read_only(surface.knots_v),
            _homogeneous(surface.control_points, surface.weights), surface.weights is not None)
    _, d1, d2 = _surface_eval_compiled(surf, uv)
    # C-contiguous (n, 3) rows as `surface.derivatives` gives them (numpy's reductions may take another
    # path on strided rows)
    parts = [np.ascontiguousarray(a) for a in (d1[:, 0], d1[:, 1], d2[:, 0, 0], d2[:, 0, 1], d2[:, 1, 1])]
    w, kmax, det = _forms(*parts)
    out = []
    for sl in (slice(0, na), slice(na, len(uv))):
        wa, ka = w[sl], kmax[sl]
        if len(ka):
            _drop_singular(wa, ka, det[sl])
        out.append((wa, ka))
    return out


def max_curvature(surface, uv) -> np.ndarray:
    """Largest absolute principal curvature ``|H| + sqrt(H^2 - K)`` of a NURBS surface at (u, v) points (n, 2).

    NaN where the surface is singular (``Su x Sv = 0``).

    Examples
    --------
    >>> from trimsurf.model import NurbsSurface
    >>> plane = NurbsSurface(1, 1, [0, 0, 1, 1], [0, 0, 1, 1],
    ...                      [[[0, 0, 0], [0, 1, 0]], [[1, 0, 0], [1, 1, 0]]])
    >>> max_curvature(plane, [[0.5, 0.5]]).tolist()
    [0.0]
    """
    return _second_forms(surface, uv)[1]


def _footprint_grid(face, mesh: TriMesh, vert_uv: np.ndarray, n_min: int) -> np.ndarray:
    """Domain samples whose spacing per direction is the median (u, v) extent of the mesh's edges there
    divided by `FOOTPRINT_DIVISIONS` (capped by `MAX_FOOTPRINT_GRID` points per direction): the grid's
    covering radius is then below the inradius of a right isosceles triangle of median size, so a gap
    in the mesh as large as one typical triangle holds a sample."""
    e = mesh.edges()
    duv = np.abs(vert_uv[e[:, 0]] - vert_uv[e[:, 1]])
    polys = loop_polygons(face)
    lo, hi = polys[0].min(axis=0), polys[0].max(axis=0)
    n = []
    for axis in (0, 1):
        x = duv[:, axis]
        x = x[np.isfinite(x) & (x > 1e-12 * max(hi[axis] - lo[axis], 1e-300))]
        step = (median(x) if len(x) else (hi[axis] - lo[axis])) / FOOTPRINT_DIVISIONS
        n.append(int(np.clip(np.ceil((hi[axis] - lo[axis]) / max(step, 1e-300)) + 1, n_min, MAX_FOOTPRINT_GRID)))
    if n[0] <= n_min and n[1] <= n_min:
        return np.zeros((0, 2))
    return sample_face_domain(face, n=(n[0], n[1]))


#: points per loop segment of the trim polygons that decide whether a far surface sample is a point of the
#: face (the 32 of the sampling leave slivers between polygon and curve whose points belong to the
#: neighbouring face: gmsh__wing_fuselage.step face 0, 1.22 x the tolerance from its own mesh)
FINE_LOOP_POINTS = 512


def _drop_outside(face, uv: np.ndarray, d: np.ndarray, batch: int = 64, cache: list | None = None) -> np.ndarray:
    """`d` with 0 for the largest surface samples that lie outside the face's trim loops, tested on fine
    loop polygons (`FINE_LOOP_POINTS`), largest first, until the largest value left is one tested
    inside (the maximum is a point of the face; smaller values are not re-tested). The fine polygons
    and their index are kept per face (`sampling._inside_loops`); `cache` is not needed any more."""
    if not face.loops or not len(d):
        return d
    d = np.array(d, dtype=np.float64)
    checked = np.zeros(len(d), dtype=bool)
    while True:
        top = int(np.argmax(d))
        if d[top] <= 0 or checked[top]:
            return d
        open_ = np.flatnonzero(~checked & (d > 0))
        cand = _top(open_, d[open_], batch)
        checked[cand] = True
        d[cand[~_inside_loops(face, uv[cand], FINE_LOOP_POINTS)]] = 0.0


def _top(idx: np.ndarray, vals: np.ndarray, batch: int) -> np.ndarray:
    """The `batch` entries of `idx` with the largest `vals`, ties in index order: the set
    ``idx[np.argsort(-vals, kind="stable")[:batch]]`` (in another order), by a partition instead of a
    full sort of every open sample at each batch."""
    n = len(vals)
    if n <= batch:
        return idx
    thr = np.partition(vals, n - batch)[n - batch]      # the batch-th largest
    above = np.flatnonzero(vals > thr)
    tie = np.flatnonzero(vals == thr)[:batch - len(above)]
    return idx[np.concatenate([above, tie])]


@functools.lru_cache(maxsize=None)
def _bary_grid(k: int) -> np.ndarray:
    """All nodes (i, j, l) / k, i + j + l = k, of a triangle's barycentric grid, ((k+1)(k+2)/2, 3)
    (read-only: built once per k and shared by every face and round)."""
    ij = np.array([(i, j) for i in range(k + 1) for j in range(k + 1 - i)], dtype=np.float64)
    out = np.column_stack([ij[:, 0], ij[:, 1], k - ij.sum(axis=1)]) / k
    out.flags.writeable = False
    return out


@functools.lru_cache(maxsize=None)
def _group_nodes(k: int, k_prev: int, k_first: int, surface_only: bool) -> tuple[np.ndarray, np.ndarray]:
    """The nodes (barycentric weights) `_sample_more` measures on a triangle sampled at k divisions that was
    sampled at k_prev before and k_first first (0: none): (mesh side, surface side), each the grid's nodes
    that are no node of either earlier grid (i / k = j / k_prev: every index times k_prev a multiple of k), the
    surface side with the corners again; with `surface_only` no corners at all (a corner's surface point is
    its foot: no farther from the mesh than the corner). Read-only, built once per key."""
    w_all = _bary_grid(k)
    if surface_only:
        w_all = w_all[w_all.max(axis=1) < 1.0]
    seen = np.zeros(len(w_all), dtype=bool)
    idx = np.rint(w_all * k).astype(np.int64)
    for kq in {k_prev, k_first} - {0}:     # the earlier grids' nodes: measured already
        seen |= np.all(idx * kq % k == 0, axis=1)
    corner = w_all.max(axis=1) >= 1.0
    out = (w_all[~seen], w_all[~seen | corner])
    for a in out:
        a.flags.writeable = False
    return out


def _enclosing_radius(p: np.ndarray) -> np.ndarray:
    """Radius of the smallest ball containing each triangle (m, 3, 3): the circumradius of an acute
    triangle, half the longest side of an obtuse one.

    For f with second derivative at most M along the triangle, f - L <= M/2 (R^2 - |x - c|^2) (the
    quadratic through the corners, c and R the circumcircle), whose largest value over the triangle is
    M/2 times this radius squared (c lies beyond the longest side of an obtuse triangle, opposite its
    midpoint).
    """
    a = np.linalg.norm(p[:, 1] - p[:, 2], axis=1)
    b = np.linalg.norm(p[:, 2] - p[:, 0], axis=1)
    c = np.linalg.norm(p[:, 0] - p[:, 1], axis=1)
    s = np.sort(np.column_stack([a, b, c]), axis=1)
    area2 = np.linalg.norm(_cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = a * b * c / (2.0 * area2)
    obtuse = s[:, 2] ** 2 >= s[:, 0] ** 2 + s[:, 1] ** 2
    return np.where(obtuse | ~np.isfinite(r), 0.5 * s[:, 2], r)


def _simplex_max(c: np.ndarray) -> np.ndarray:
    """max over barycentric l of sum_{i<j} l_i l_j c_ij, for c (m, 3) = (c_01, c_12, c_20) >= 0: an edge
    midpoint (c_ij / 4) or the interior critical point of the quadratic form."""
    m = len(c)
    mat = np.zeros((m, 3, 3))
    for (i, j), col in zip(((0, 1), (1, 2), (2, 0)), range(3)):
        mat[:, i, j] = mat[:, j, i] = c[:, col]
    best = c.max(axis=1) / 4.0
    with np.errstate(all="ignore"):
        det = np.linalg.det(mat)
        ok = np.abs(det) > 1e-300
        if ok.any():
            x = np.linalg.solve(mat[ok], np.ones((int(ok.sum()), 3, 1)))[..., 0]
            tot = x.sum(axis=1)
            lam = x / tot[:, None]
            val = 0.5 / tot                     # (l.C.l) / 2 = mu / 2 with mu = 1 / (1.C^-1.1)
            good = np.all(lam >= 0, axis=1) & np.isfinite(val) & (val > 0)
            idx = np.flatnonzero(ok)[good]
            best[idx] = np.maximum(best[idx], val[good])
    return best


def _curvature_bound(st: _FaceState, tri_uv_ok: np.ndarray, rows: np.ndarray | None = None
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Per triangle: the interpolation bound's coefficient beta (the bound is beta / k^2 on a grid of k
    divisions) and the curvature kappa (for the 1 / (1 - kappa d) factor of the distance function).

    With q_ij = `CURVATURE_MARGIN` x the largest |e_ij . W . e_ij| (W the shape operator, at the
    triangle's corners' feet and its (u, v) centre; e_ij its edges), a function whose second
    derivative along e_ij is at most q_ij / |e_ij|^2 exceeds its linear interpolation by at most
    ``max_l sum_{i<j} l_i l_j q_ij / 2`` (exact for a quadratic). Where the corners' (u, v) do not
    make a triangle of the face (across a periodic seam) the face's largest sampled curvature times
    |e_ij|^2 is used.

    `rows` (m,) bool, optional: the triangles whose values are needed (the others are skipped and get
    NaN): the forms are computed at every vertex's foot as without `rows`, and at the centres of these
    triangles only; the face's largest curvature of the fallback is then over the vertices and these
    centres.
    """
    return _curvature_bounds([(st, tri_uv_ok, rows)])[0]


def _curvature_bounds(items: list) -> list:
    """`_curvature_bound` of each (state, tri_uv_ok, rows) of `items`, as a list of (beta, kappa): each face's
    derivatives evaluated on its own surface, the second forms (`_forms`) and the simplex maxima
    (`_simplex_max`) over all faces' rows in one call each (both row by row: each row's numbers do not
    depend on the others), the rest per face as before (each face keeps its own medians and maximum)."""
    from ..geom.projection import _surface_eval_compiled

    out = [None] * len(items)
    todo = []
    for j, (st, tri_uv_ok, rows) in enumerate(items):
        if rows is not None and not rows.any():
            out[j] = (np.full(len(st.mesh.triangles), np.nan), np.full(len(st.mesh.triangles), np.nan))
            continue
        if rows is not None:
            tri_uv_ok = tri_uv_ok & rows
        t = st.mesh.triangles
        s = st.face.surface
        used = np.isfinite(st.vert_uv[:, 0])
        # the forms at the vertices' feet and at the triangles' (u, v) centres, from one evaluation
        # (`_second_forms_two`'s steps up to `_forms`)
        uv_a, uv_b = st.vert_uv[used], st.vert_uv[t[tri_uv_ok]].mean(axis=1)
        uv = np.concatenate([uv_a, uv_b]).astype(np.float64, copy=False)
        surf = (int(s.degree_u), int(s.degree_v), read_only(s.knots_u), read_only(s.knots_v),
                _homogeneous(s.control_points, s.weights), s.weights is not None)
        _, d1, d2 = _surface_eval_compiled(surf, uv)
        todo.append((j, st, tri_uv_ok, rows, used, len(uv_a), (d1[:, 0], d1[:, 1], d2[:, 0, 0], d2[:, 0, 1],
                                                                d2[:, 1, 1])))
    if not todo:
        return out
    # C-contiguous (n, 3) rows as `_second_forms_two` gives them
    parts = [np.concatenate([it[6][c] for it in todo]) for c in range(5)]
    w_all, k_all, det_all = _forms(*parts)
    qs = []
    pos = 0
    for j, st, tri_uv_ok, rows, used, na, d in todo:
        n = len(d[0])
        w, kmax, det = w_all[pos:pos + n], k_all[pos:pos + n], det_all[pos:pos + n]
        pos += n
        halves = []
        for sl in (slice(0, na), slice(na, n)):
            wa, ka = w[sl], kmax[sl]
            if len(ka):
                _drop_singular(wa, ka, det[sl])
            halves.append((wa, ka))
        (wa, ka), (wb, kb) = halves
        t = st.mesh.triangles
        nv = len(st.vert_uv)
        wv = np.full((nv, 3, 3), np.nan)
        kv = np.full(nv, np.nan)
        m = len(t)
        wc = np.full((m, 3, 3), np.nan)
        kc = np.full(m, np.nan)
        wv[used], kv[used] = wa, ka
        wc[tri_uv_ok], kc[tri_uv_ok] = wb, kb
        p = st.mesh.vertices[t]
        e = np.stack([p[:, 1] - p[:, 0], p[:, 2] - p[:, 1], p[:, 0] - p[:, 2]], axis=1)      # (m, 3 edges, 3)
        q = np.zeros((m, 3))
        for wt in (wv[t[:, 0]], wv[t[:, 1]], wv[t[:, 2]], wc):
            v = np.abs(np.einsum("mei,mij,mej->me", e, wt, e))
            q = np.fmax(q, v)
        kt = np.fmax(np.fmax(np.fmax(kv[t[:, 0]], kv[t[:, 1]]), kv[t[:, 2]]), kc)
        if rows is not None:
            kt[~rows] = np.nan
            kt_all = np.fmax(kt, np.fmax(np.fmax(kv[t[:, 0]], kv[t[:, 1]]), kv[t[:, 2]]))
        else:
            kt_all = kt
        fin = np.isfinite(kt_all)
        face_max = float(kt_all[fin].max()) if fin.any() else 0.0
        fin = np.isfinite(kt)
        fallback = ~(fin & tri_uv_ok)
        kt = np.where(fallback, face_max, kt)
        q = np.where(fallback[:, None], face_max * np.einsum("mei,mei->me", e, e), q)
        qs.append(q)
        out[j] = kt
    sm = np.split(_simplex_max(np.concatenate(qs)), np.cumsum([len(q) for q in qs])[:-1])
    for (j, *_), smj in zip(todo, sm):
        out[j] = (CURVATURE_MARGIN * smj / 2.0, CURVATURE_MARGIN * out[j])
    return out


def refine_deviation(devs: list, states: list, *, rel: float = 0.01, tol_rel: float = 1e-10,
                     max_density: int = MAX_DENSITY) -> tuple[list, float]:
    """Resample, more densely, every triangle that could hide a deviation above the overall maximum.

    Each triangle t is sampled on a barycentric grid of k divisions per edge
    (k = the starting density, then as below), both directions: mesh points
    projected onto the surface, and surface points over the triangle's own
    (u, v) footprint (the barycentric combination of its corners' feet)
    measured to the face's mesh; D_t is its largest sample. Between the
    samples of one grid sub-triangle (edges e_ij / k) a function whose second
    derivative along e_ij is at most q_ij / |e_ij|^2 exceeds the samples'
    linear interpolation by at most ``max_l sum_{i<j} l_i l_j q_ij / (2 k^2)``
    (l barycentric; exact for a quadratic). Along a triangle the distance to
    the surface has second derivative ``II(e, e) / (1 - kappa d)`` (II the
    second fundamental form), the distance of a surface point to its
    triangle's plane ``n . S''``; so q_ij = `CURVATURE_MARGIN` x the largest
    |e_ij . W . e_ij| (W the shape operator) at the triangle's corners' feet
    and its (u, v) centre (`_curvature_bound`), and the bound is
    ``B_t = D_t + beta_t / ((1 - kappa_t D_t) k^2)``. Triangles with B_t above
    ``(1 + rel) G`` (G the largest sample over all faces so far) are sampled
    again at the smallest k' > k whose bound with the current D_t meets
    ``(1 + rel) G`` (`_smallest_density`; at most `max_density`), until none is
    left: the same stopping rule as doubling, with fewer nodes (the grids are
    not nested, so the maximum may come out lower than doubling's, still
    within ``rel`` of the bound). Nodes of the previous grid and of the first
    pass's that the new grid repeats are not measured again. With pruning (the report's measurement,
    `_shell_deviation` with ``skip``), a mesh-side node whose chord bound (`_chord_bound`) is below both its
    triangle's largest value and the face's mesh -> surface maximum is not projected: its value could
    change neither, so every D_t, bound and decision is the same; a node still projected keeps its
    warm-started run when that ends 100 tolerances below the same threshold (the full search could end
    at most 10 tolerances above it).

    What the result bounds: the maximum stays a sampled figure, within ``rel``
    of the bound; ``max(B_t)`` (returned, and each Deviation's ``max_bound``)
    bounds the true two-sided deviation provided (a) the curvature sampled at
    each triangle's corners and centre, x `CURVATURE_MARGIN`, bounds it
    between them (sampled, not proven), (b) surface -> mesh, the nearest mesh
    point lies in the plane of a triangle (near a convex mesh edge the
    distance is the edge's, convex across it, whose maximum the edge samples
    catch), and (c) the projection finds the global foot. Gaps in the mesh
    wider than about one triangle are caught by the (u, v) grid that follows
    the triangles' size (`_footprint_grid`); surface samples farther than
    half the maximum are kept only inside fine trim polygons (`_drop_outside`).

    Returns
    -------
    (list of Deviation, float)
        The Deviations with the refined maxima (and ``max_bound``, ``n_refined``), and the overall bound.
    """
    devs = list(devs)
    live = [i for i, st in enumerate(states) if st is not None and st.mesh.n_triangles]
    if not live:
        return devs, float(max((d.max_two_sided for d in devs if d is not None), default=float("nan")))
    info = {}
    corners, radii = _face_radii(states, live)
    oks = []
    for i, r in zip(live, radii):
        st = states[i]
        t = st.mesh.triangles
        p = corners[i]
        cuv = st.vert_uv[t]                                    # (m, 3, 2) corner feet
        ok = np.all(np.isfinite(cuv.reshape(len(t), -1)), axis=1) if st.two_sided else np.zeros(len(t), bool)
        if st.skip is not None:
            ok &= ~st.skip                                     # skipped: no footprint samples either
        if ok.any():
            # corners' (u, v) span a triangle of the face (not across a periodic seam): its centre maps near
            # the mesh triangle's centroid
            c3 = st.face.surface.evaluate(cuv[ok].mean(axis=1))
            ok[ok] = np.linalg.norm(c3 - p[ok].mean(axis=1), axis=1) <= 2.0 * r[ok] + 2.0 * st.tri_max[ok]
        oks.append((st, ok, None if st.skip is None else ~st.skip))
    for i, (beta, kap), (st, ok, _) in zip(live, _curvature_bounds(oks), oks):
        info[i] = (beta, ok, kap, np.zeros(len(st.mesh.triangles), dtype=bool))
    # the surface -> mesh side over each triangle's own footprint at the starting density first
    for i in live:
        st = states[i]
        if st.two_sided:
            _sample_more(devs, states, info, i, np.flatnonzero(info[i][1]), tol_rel, surface_only=True)
    _complete_first_pass(devs, states, info, live, tol_rel)     # the first pass's pending nodes that could matter

    def bounds(i, k=None):
        st = states[i]
        beta, ok, kap, _ = info[i]
        b = st.tri_max + beta / np.maximum(1.0 - kap * st.tri_max, 0.5) / (st.density if k is None else k) ** 2
        # a skipped triangle: its a-priori bound (proven, and at most the maxima: never refined)
        return b if st.skip is None else np.where(st.skip, st.apriori, b)

    first = {i: states[i].density.copy() for i in live}
    # each face's bounds and the largest one it may still refine, recomputed only after the face was sampled
    # again (they depend on its own values alone): a face whose largest is within the target has nothing to do
    cached = {}
    stale = set(live)
    while True:
        g = max(_nonneg(d.max_two_sided) for d in devs if d is not None)
        target = (1.0 + rel) * g
        for i in stale:
            b = bounds(i)
            el = (states[i].density < max_density) & (True if states[i].skip is None else ~states[i].skip)
            cached[i] = (b, el, float(np.fmax.reduce(b[el], initial=-np.inf)))
        stale = set()
        todo = {}
        for i in live:
            b, el, top = cached[i]
            if top > target:
                c = np.flatnonzero((b > target) & el)
                if len(c):
                    todo[i] = c
        if not todo:
            break
        for i, cand in todo.items():
            st = states[i]
            beta, _, kap = info[i][:3]
            prev = st.density[cand].copy()
            st.density[cand] = _smallest_density(st.tri_max[cand], beta[cand], kap[cand], prev, target, max_density)
            _sample_more(devs, states, info, i, cand, tol_rel, prev=prev, first=first[i][cand])
            stale.add(i)
    overall = -np.inf
    for i in live:
        b = float(np.max(bounds(i), initial=0.0))
        overall = max(overall, b)
        devs[i] = _replace(devs[i], max_bound=max(b, devs[i].max_two_sided), n_refined=int(info[i][3].sum()))
    return devs, float(overall)


def _face_radii(states: list, live: list) -> tuple[dict, list]:
    """The corners (m, 3, 3) of each live face state's triangles, and their `_enclosing_radius` (one list
    entry per face of `live`) from one call over all faces (row by row: the numbers of one call per face)."""
    corners = {i: states[i].mesh.vertices[states[i].mesh.triangles] for i in live}
    sizes = np.cumsum([len(corners[i]) for i in live])[:-1]
    return corners, np.split(_enclosing_radius(np.concatenate([corners[i] for i in live])), sizes)


def _nonneg(x: float) -> float:
    """``float(np.nanmax([x, 0.0]))`` of a float: x where it is above 0, else 0 (NaN included)."""
    return x if x > 0.0 else 0.0


def _smallest_density(dmax: np.ndarray, beta: np.ndarray, kap: np.ndarray, k: np.ndarray, target: float,
                      max_density: int) -> np.ndarray:
    """Per triangle, the smallest division count k' > k (at most `max_density`) whose bound
    ``dmax + beta / (max(1 - kap dmax, 0.5) k'^2)`` (`refine_deviation`'s B_t with the current largest
    sample D_t = `dmax`) is at most `target`: ``ceil(sqrt(beta / (den (target - dmax))))``, then checked
    with the bound's own expression (and raised by one where rounding left it above)."""
    den = np.maximum(1.0 - kap * dmax, 0.5)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        need = np.sqrt(beta / (den * (target - dmax)))
    need = np.where(np.isfinite(need) & (target > dmax), np.minimum(need, max_density), max_density)
    kk = np.clip(np.ceil(need).astype(np.int64), k + 1, max_density)
    for _ in range(3):
        low = (dmax + beta / den / kk ** 2 > target) & (kk < max_density)
        if not low.any():
            break
        kk[low] += 1
    return kk


def _groups(k: np.ndarray, kp: np.ndarray, k1: np.ndarray) -> np.ndarray:
    """``np.unique(np.column_stack([k, kp, k1]), axis=0)`` for non-negative integer division counts: the
    distinct rows in lexicographic order, by one integer key per row (``np.unique`` over rows sorts a
    structured view, ~10x slower on these short arrays)."""
    if not len(k):
        return np.zeros((0, 3), dtype=np.int64)
    rows = np.stack([k, kp, k1]).astype(np.int64, copy=False)
    base = int(rows.max()) + 1
    key = (rows[0] * base + rows[1]) * base + rows[2]
    key.sort()
    key = key[np.concatenate(([True], key[1:] != key[:-1]))]
    out = np.empty((len(key), 3), dtype=np.int64)
    np.floor_divide(key, base * base, out=out[:, 0])
    np.remainder(key // base, base, out=out[:, 1])
    np.remainder(key, base, out=out[:, 2])
    return out


def _single_density(dk: np.ndarray) -> bool:
    """Whether every entry of `dk` (division counts, non-empty) is the same (`_sample_more`'s one group)."""
    return bool(dk.min() == dk.max())


def _sample_more(devs, states, info, i, cand, tol_rel, surface_only=False, prev=None, first=None) -> None:
    """Sample triangles `cand` of face state i at their current density, both directions (or the surface
    -> mesh side only), and fold the values into the state and the Deviation.

    `prev` (per triangle of `cand`): the density each was sampled with before, `first` the first pass's.
    The nodes of the new grid that are nodes of either (i / k = j / k_prev: every index times k_prev a
    multiple of k) were measured already, both directions (the surface side at every node but the
    corners, which are measured again), and are not measured again."""
    st = states[i]
    if not len(cand):
        return
    r, ok, _, refined = info[i]
    if not surface_only:
        refined[cand] = True
    dev = devs[i]
    t = st.mesh.triangles
    mx, where, mx2, where2 = dev.max_mesh_to_target, dev.where_mesh_to_target, dev.max_target_to_mesh, \
        dev.where_target_to_mesh
    n1, n2 = dev.n_mesh_samples, dev.n_target_samples
    dk = st.density[cand]
    one = prev is None and first is None and _single_density(dk)
    if one:
        # `refine_deviation`'s first call per face (every triangle at the starting density, none sampled
        # before): the one group (k, 0, 0) holds every triangle of `cand`, in order
        groups = [[int(dk[0]), 0, 0]]
    else:
        kp = np.zeros(len(cand), dtype=np.int64) if prev is None else np.asarray(prev, dtype=np.int64)
        k1 = np.zeros(len(cand), dtype=np.int64) if first is None else np.asarray(first, dtype=np.int64)
        groups = _groups(dk, kp, k1).tolist()
    parts = ([], [])            # per side: (triangles, their new nodes) of each (k, k_prev, k_first) group
    for k, k_prev, k_first in groups:
        tri = cand if one else cand[(dk == k) & (kp == k_prev) & (k1 == k_first)]
        nodes = _group_nodes(int(k), int(k_prev), int(k_first), bool(surface_only))
        for side in (0, 1):
            if (side == 0 and surface_only) or (side == 1 and not st.two_sided):
                continue
            w = nodes[side]
            if len(w):
                parts[side].append((tri, w))
    # every group's nodes in one batch per side (one projection call, one mesh search): the mesh side
    # first, each node's threshold from its triangle's values before this call's surface side, as before
    if parts[0]:
        rows = np.concatenate([np.repeat(tri, len(w)) for tri, w in parts[0]])
        ww = np.concatenate([np.tile(w, (len(tri), 1)) for tri, w in parts[0]])
        on_edge = np.concatenate([np.tile(np.any(w == 0.0, axis=1), len(tri)) for tri, w in parts[0]])
        pts = np.einsum("kj,kjd->kd", ww, st.mesh.vertices[t[rows]])
        uv0 = np.einsum("kj,kjd->kd", ww, st.vert_uv[t[rows]])
        good = np.all(np.isfinite(uv0), axis=1)
        # a node below both its triangle's largest value so far and the face's largest mesh sample
        # changes neither: the projection may stop at its warm-started run (`skip_below`)
        below = np.minimum(st.tri_max[rows], mx) if np.isfinite(mx) else None
        d = np.full(len(rows), -np.inf)
        todo = np.ones(len(rows), dtype=bool)
        if st.prune and below is not None:
            # a node whose chord distance |S(x(w)) - p(w)| stays below its threshold cannot reach it
            # (`_chord_bound`): not projected
            todo = ~(_chord_bound(st.face.surface, uv0, pts, tol_rel) < below)
            # `project_to_surface` settles a warm run at d <= _SETTLED_FRACTION x skip_below - 100 tol, and
            # the full search could only end within 10 tol above d (its docstring): with the threshold
            # over _SETTLED_FRACTION, a settled node stays below the threshold itself either way
            below = below / _SETTLED_FRACTION
        for sel, start in ((good & todo, True), (~good & todo, False)):
            if sel.all():
                d = _project_once(pts, uv0 if start else None, on_edge, st.face, tol_rel, below if start else None)
                break
            if sel.any():
                d[sel] = _project_once(pts[sel], uv0[sel] if start else None, on_edge[sel], st.face, tol_rel,
                                       below[sel] if start and below is not None else None)
        np.maximum.at(st.tri_max, rows, d)
        j = int(np.argmax(d))
        if d[j] > mx:
            mx, where = float(d[j]), pts[j].copy()
        n1 += int(todo.sum())
    if parts[1]:
        mx2, where2, n2 = _sample_surface_side(st, ok, parts[1], mx2, where2, n2)
    devs[i] = _replace(dev, max_mesh_to_target=mx, where_mesh_to_target=where, max_target_to_mesh=mx2,
                      where_target_to_mesh=where2, n_mesh_samples=n1, n_target_samples=n2,
                      max_two_sided=float(np.nanmax([mx, mx2])))


#: `_chord_bound`'s allowance for the projection's own convergence, in projection tolerances (tol_rel x the
#: control net's diagonal): the Newton iteration stops within a few tol of a foot
CHORD_SLACK_TOL = 100.0


def _chord_bound(surface, uv: np.ndarray, pts: np.ndarray, tol_rel: float) -> np.ndarray:
    """Per node (uv (n, 2), pts (n, 3)): ``|S(x) - p| + slack``, x the (u, v) clamped to the domain, with
    slack = `CHORD_SLACK_TOL` x the projection tolerance + 64 ulp of the coordinates; inf where x or S(x) is
    not finite.

    S(x) is a point of the (untrimmed) surface, so the distance of p to the surface is at most |S(x) - p|;
    where p = p(w) is a point of a triangle of the face's mesh and x = x(w) the same barycentric
    combination of its corners' feet, |S(x(w)) - p(w)| also bounds the distance of the surface point
    S(x(w)) to the mesh. Both samples a refinement node stands for are then at most this value: the
    projection (a Newton run from x itself, which only descends, then restarts that keep closer feet) ends
    within a few tolerances of a distance at most |S(x) - p|, and the mesh search is exact up to the
    rounding of the coordinates. A node whose bound is below a threshold the caller compares against
    (its triangle's largest value, the face's maximum) therefore cannot reach it: not measuring it
    changes no maximum (`_sample_more`). One case could differ: a warm run that does not converge is
    redone from a seed and replaced by that run, which may end in a farther basin; that value (above
    the true distance, which is at most the bound) is then not taken, and the pruned figure is the more
    exact one (not seen on the 34 shared meshes: `benchmarks/measure_same.py`)."""
    n = len(pts)
    out = np.full(n, np.inf)
    fin = np.all(np.isfinite(uv), axis=1) if n else np.zeros(0, dtype=bool)
    if not fin.any():
        return out
    (u0, u1), (v0, v1) = surface.domain
    x = np.column_stack([np.clip(uv[fin, 0], u0, u1), np.clip(uv[fin, 1], v0, v1)])
    q = surface.evaluate(x)
    p = pts[fin]
    cp = np.asarray(surface.control_points, dtype=np.float64).reshape(-1, 3)
    diag = float(np.linalg.norm(cp.max(axis=0) - cp.min(axis=0))) or 1.0
    slack = CHORD_SLACK_TOL * tol_rel * diag + 64.0 * np.finfo(np.float64).eps * (
        np.abs(p).max(axis=1) + np.abs(q).max(axis=1))
    val = np.linalg.norm(q - p, axis=1) + slack
    out[fin] = np.where(np.isfinite(val), val, np.inf)
    return out


def _project_once(pts: np.ndarray, uv0: np.ndarray | None, on_edge: np.ndarray, face, tol_rel: float,
                  below: np.ndarray | None = None):
    """``project_to_face(pts, face, uv0=uv0, skip_below=below).distance`` with each distinct (point, start)
    projected once (its threshold the smallest of its repeats').

    `pts` are barycentric grid nodes of triangles, `on_edge` those with a zero weight. A node on an edge
    of two triangles sampled at the same density is the same point with the same start (the
    same two corners, the same integer / k weights: the same sums bit for bit), and the projection is
    a function of each point and its start alone (`geom.projection`: point by point), so its repeat
    takes the first one's distance: the values are those of projecting every node. With `below`, a
    node's value may be its warm-started run's instead of the full search's where both stay below its
    threshold (`project_to_surface`'s ``skip_below``): every maximum that reaches a threshold is the
    same."""
    if uv0 is None:
        below = None
    idx = np.flatnonzero(on_edge)
    if len(idx) < 2:
        return project_to_face(pts, face, tol_rel=tol_rel, uv0=uv0, skip_below=below).distance
    key = pts[idx] if uv0 is None else np.concatenate([pts[idx], uv0[idx]], axis=1)
    key = np.ascontiguousarray(key).view(np.dtype((np.void, key.dtype.itemsize * key.shape[1]))).ravel()
    _, first, inv = np.unique(key, return_index=True, return_inverse=True)
    inv = inv.ravel()
    if len(first) == len(idx):
        return project_to_face(pts, face, tol_rel=tol_rel, uv0=uv0, skip_below=below).distance
    keep = np.ones(len(pts), dtype=bool)
    keep[idx] = False
    keep[idx[first]] = True
    rows = np.flatnonzero(keep)
    b_keep = None
    if below is not None:
        b = below.copy()
        lowest = np.full(len(first), np.inf)
        np.minimum.at(lowest, inv, below[idx])
        b[idx[first]] = lowest
        b_keep = b[rows]
    d_keep = project_to_face(pts[rows], face, tol_rel=tol_rel, uv0=None if uv0 is None else uv0[rows],
                             skip_below=b_keep).distance
    d = np.empty(len(pts))
    d[rows] = d_keep
    d[idx] = d[idx[first]][inv]
    return d


def _sample_surface_side(st, ok, parts, mx2, where2, n2):
    """Surface -> mesh samples at barycentric nodes w of the (u, v) footprints of triangles tri, for each
    (tri, w) of `parts` (those with `ok` footprints), in one batch; folds them into ``st.tri_max`` and
    returns the updated (max, where, count)."""
    t = st.mesh.triangles
    parts = [(tri[ok[tri]], w) for tri, w in parts]
    parts = [(tri, w) for tri, w in parts if len(tri)]
    if not parts:
        return mx2, where2, n2
    rows2 = np.concatenate([np.repeat(tri, len(w)) for tri, w in parts])
    ww2 = np.concatenate([np.tile(w, (len(tri), 1)) for tri, w in parts])
    uv = np.einsum("kj,kjd->kd", ww2, st.vert_uv[t[rows2]])
    q = st.face.surface.evaluate(uv)
    # a footprint point outside the trimmed region (a chord of a curved border) is no point of the face
    inside = np.ones(len(uv), dtype=bool) if st.polys is None else _inside_loops(st.face, uv)
    if st.loc is None or not np.all(np.isfinite(q)):
        near = closest_points_on_mesh(q, st.mesh).distance
    else:
        near = _closest(q, st.loc, hint=rows2).distance     # the footprint's own triangle bounds the search
    d2 = np.where(inside, near, 0.0)
    d2 = _drop_outside(st.face, uv, d2, cache=st.fine)
    np.maximum.at(st.tri_max, rows2, d2)
    j = int(np.argmax(d2))
    if d2[j] > (mx2 if np.isfinite(mx2) else -np.inf):
        mx2, where2 = float(d2[j]), q[j].copy()
    return mx2, where2, n2 + int(inside.sum())

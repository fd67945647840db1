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

from dataclasses import dataclass

import numpy as np

from ..errors import InputError, MeshError
from ..geom.projection import project_to_surface
from ..model import Shell, TriMesh
from ._results import ResultMixin
from .closest_point import closest_points_on_mesh
from .sampling import as_face, distance_outside_face, sample_face_domain, sample_triangles

__all__ = ["Deviation", "ShellDeviation", "surface_deviation", "shell_deviation", "mesh_deviation",
           "project_to_face"]


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
        by more than `trim_tol_uv` (in (u, v)).
    max_outside_trim_uv : float
        Largest (u, v) distance of such a foot from the trimmed region (0 when all inside).
    per_triangle_max : (m,) float64
        Largest mesh -> target distance among each triangle's samples (its corners and edges included).
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


def _stats(d: np.ndarray, pts: np.ndarray) -> tuple[float, float, np.ndarray]:
    if not len(d):
        return float("nan"), float("nan"), np.full(3, np.nan)
    k = int(np.argmax(d))
    return float(d[k]), float(np.sqrt(np.mean(d ** 2))), pts[k].copy()


def _check_mesh(mesh, name: str) -> None:
    if not isinstance(mesh, TriMesh):
        raise InputError(f"{name} needs a TriMesh; got {type(mesh).__name__}")
    if not mesh.n_triangles:
        raise MeshError(f"{name}: mesh has no triangles")


def project_to_face(points, face, *, tol_rel: float = 1e-10, uv0=None):
    """Project points (n, 3) onto the surface of a face (or a NurbsSurface); returns `geom.projection.Projection`.

    ``uv0`` (n, 2), optional: warm-start parameters (see `geom.projection.project_to_surface`).
    """
    s = as_face(face).surface
    return project_to_surface(np.asarray(points, dtype=np.float64).reshape(-1, 3), s.degree_u, s.degree_v,
                              s.knots_u, s.knots_v, s.control_points, s.weights, tol_rel=tol_rel, uv0=uv0)


def surface_deviation(mesh: TriMesh, target, *, density: int = 4, n_domain: int = 64, two_sided: bool = True,
                      tol_rel: float = 1e-10, trim_tol_uv: float | None = None) -> Deviation:
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
    _check_mesh(mesh, "surface_deviation")
    face = as_face(target)
    samples = sample_triangles(mesh, density=density)
    # the mesh's per-vertex (u, v), interpolated at the samples, warm-starts the projection
    uv0 = None if mesh.uv is None else np.einsum("kj,kjd->kd", samples.barycentric,
                                                  mesh.uv[mesh.triangles[samples.triangle]])
    proj = project_to_face(samples.points, face, tol_rel=tol_rel, uv0=uv0)
    d = proj.distance
    mx, rms, where = _stats(d, samples.points)
    out_uv = distance_outside_face(face, proj.uv)
    if trim_tol_uv is None:
        (u0, u1), (v0, v1) = face.surface.domain
        box = np.array([[u0, v0], [u1, v1]]) if not face.loops else np.array(
            [face.loops[0].polyline(8).min(axis=0), face.loops[0].polyline(8).max(axis=0)])
        trim_tol_uv = 1e-3 * float(np.linalg.norm(box[1] - box[0]))
    outside = int(np.count_nonzero(out_uv > trim_tol_uv))
    mx2, rms2, where2, n2 = float("nan"), float("nan"), np.full(3, np.nan), 0
    if two_sided:
        uv = sample_face_domain(face, n=n_domain)
        pts = face.surface.evaluate(uv)
        cp = closest_points_on_mesh(pts, mesh)
        mx2, rms2, where2 = _stats(cp.distance, pts)
        n2 = len(pts)
    return Deviation(mx, rms, where, len(d), mx2, rms2, where2, n2,
                     float(np.nanmax([mx, mx2])), int(np.count_nonzero(~proj.converged)), outside,
                     float(out_uv.max(initial=0.0)),
                     samples.per_triangle_max(mesh, d))


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
                    tol_rel: float = 1e-10) -> ShellDeviation:
    """Deviation of a mesh from each face of a shell, by the mesh's ``face_id``, and overall.

    Parameters are those of `surface_deviation`; surface -> mesh is measured
    against the triangles of the same face.

    Raises
    ------
    InputError
        Not a Shell; MeshError when the mesh has no face_id or a face_id out of range.
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
    results: list[Deviation | None] = []
    for i, face in enumerate(shell.faces):
        sel = mesh.face_id == i
        if not sel.any():
            results.append(None)
            continue
        results.append(surface_deviation(mesh.submesh(sel), face, density=density, n_domain=n_domain,
                                         two_sided=two_sided, tol_rel=tol_rel))
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
        worst_face=worst)


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

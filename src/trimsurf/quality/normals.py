"""Normal deviation and the height-field slope criterion of the joining paper.

`normal_deviation` compares each triangle's normal with the exact, oriented
surface normal at the closest surface points of the triangle's samples.

`height_field_slope` implements the paper's "normal-vector error". With the
unit normal n(u, v) = (F_u x F_v) / |F_u x F_v| and the height eta defined by
M(u, v) = F(u, v) + eta(u, v) n(u, v) in |M|, the criterion is max_j L_j, where
L_j is the smallest L with |eta(p1) - eta(p2)| <= L |p1 - p2| for p1, p2 in
I_j, the inverse image of triangle T_j. As in the paper's practical proxy,
"the slope of eta on I_j is replaced by the slope measured only between the
three corner points of I_j", so

    L_j = max over the edges (i, k) of T_j of |eta_i - eta_k| / |p_i - p_k|,

with p the (u, v) of the corners' closest surface points (``metric="uv"``, the
paper's definition) or, to be independent of the parameterization, their 3D
feet F(p) (``metric="3d"``). The absolute error of eq. (1), sup |eta|, is
reported alongside, at the vertices.

References
----------
join-mesh-patches-whitney.txt, Sec. II: eq. (1) (absolute error) and the
Lipschitz condition defining L_j with its three-corner proxy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..model import TriMesh
from ._results import ResultMixin
from .deviation import _check_mesh, project_to_face
from .sampling import as_face, sample_triangles

__all__ = ["NormalDeviation", "normal_deviation", "HeightFieldSlope", "height_field_slope"]


@dataclass(frozen=True, eq=False)
class NormalDeviation(ResultMixin):
    """Angles between triangle normals and the oriented surface normals (degrees).

    Attributes
    ----------
    max_deg, rms_deg : float
        Over all (sample, triangle) pairs: each triangle at its corners, edge
        points and interior nodes (180 for a triangle facing the wrong way).
    where : (3,) float64
        Sample with the largest angle.
    worst_triangle : int
    n_samples : int
        (sample, triangle) pairs compared.
    per_triangle_max_deg : (m,) float64
    n_singular : int
        Samples whose foot has no surface normal (F_u x F_v = 0); left out.
    """

    max_deg: float
    rms_deg: float
    where: np.ndarray
    worst_triangle: int
    n_samples: int
    per_triangle_max_deg: np.ndarray
    n_singular: int


def normal_deviation(mesh: TriMesh, target, *, density: int = 2, tol_rel: float = 1e-10) -> NormalDeviation:
    """Angle between each triangle's normal and the exact surface normal at its samples' feet.

    Parameters
    ----------
    mesh : TriMesh
    target : NurbsSurface or TrimmedFace
        The face's normal is oriented by `TrimmedFace.same_sense`.
    density : int
        Barycentric grid divisions per edge (`sample_triangles`).
    tol_rel : float
        Projection tolerance.

    Returns
    -------
    NormalDeviation

    Raises
    ------
    InputError
        Wrong types; MeshError for a mesh without triangles.

    Examples
    --------
    >>> from trimsurf.model import NurbsSurface
    >>> plane = NurbsSurface(1, 1, [0, 0, 1, 1], [0, 0, 1, 1],
    ...                      [[[0, 0, 0], [0, 1, 0]], [[1, 0, 0], [1, 1, 0]]])
    >>> m = TriMesh([[0, 0, 0], [1, 0, 0], [1, 1, 0]], [[0, 1, 2]])
    >>> normal_deviation(m, plane).max_deg
    0.0
    """
    _check_mesh(mesh, "normal_deviation")
    face = as_face(target)
    samples = sample_triangles(mesh, density=density)
    proj = project_to_face(samples.points, face, tol_rel=tol_rel)
    ns = face.oriented_normals(proj.uv)
    nt = mesh.triangle_normals()
    with np.errstate(invalid="ignore", divide="ignore"):
        nt = nt / np.linalg.norm(nt, axis=1)[:, None]
    si, ti = samples.incidence(mesh)  # every triangle is compared at all of its samples
    cos = np.einsum("ij,ij->i", ns[si], nt[ti])
    ok = np.isfinite(cos)
    ang = np.degrees(np.arccos(np.clip(np.where(ok, cos, 1.0), -1.0, 1.0)))
    per = np.zeros(mesh.n_triangles)
    np.maximum.at(per, ti[ok], ang[ok])
    k = int(np.argmax(np.where(ok, ang, -1.0)))
    return NormalDeviation(
        max_deg=float(ang[ok].max(initial=0.0)),
        rms_deg=float(np.sqrt(np.mean(ang[ok] ** 2))) if ok.any() else float("nan"),
        where=samples.points[si[k]].copy(),
        worst_triangle=int(ti[k]),
        n_samples=int(ok.sum()),
        per_triangle_max_deg=per,
        n_singular=int((~ok).sum()),
    )


@dataclass(frozen=True, eq=False)
class HeightFieldSlope(ResultMixin):
    """The joining paper's height field over a surface and its slope (Sec. II).

    Attributes
    ----------
    max_slope : float
        max_j L_j (dimensionless for ``metric="3d"``; model units per parameter unit for "uv").
    worst_triangle : int
    p95_slope : float
    max_abs_height : float
        sup |eta| over the vertices (eq. (1) at the corners).
    metric : str
        "uv" or "3d".
    per_triangle : (m,) float64
        L_j (inf where two corners share a foot).
    heights : (n,) float64
        eta at every vertex (NaN at unused vertices), signed along n = F_u x F_v / |F_u x F_v|.
    n_undefined : int
        Triangles with two corners on the same foot (L_j infinite).
    """

    max_slope: float
    worst_triangle: int
    p95_slope: float
    max_abs_height: float
    metric: str
    per_triangle: np.ndarray
    heights: np.ndarray
    n_undefined: int


def height_field_slope(mesh: TriMesh, target, *, metric: str = "uv", tol_rel: float = 1e-10) -> HeightFieldSlope:
    """Height eta of each vertex over the surface and the per-triangle slope L_j (paper Sec. II).

    Parameters
    ----------
    mesh : TriMesh
    target : NurbsSurface or TrimmedFace
    metric : {"uv", "3d"}
        Distance between corners: in the parameter domain (the paper's
        definition) or between their 3D feet.
    tol_rel : float
        Projection tolerance.

    Returns
    -------
    HeightFieldSlope

    Raises
    ------
    InputError
        Unknown metric or wrong types; MeshError for a mesh without triangles.

    References
    ----------
    join-mesh-patches-whitney.txt, Sec. II: M(u, v) = F(u, v) + eta(u, v) n(u, v);
    eq. (1) sup |eta|; the Lipschitz constant L_j of eta on I_j, measured
    between the three corners of I_j.

    Examples
    --------
    >>> from trimsurf.model import NurbsSurface
    >>> plane = NurbsSurface(1, 1, [0, 0, 1, 1], [0, 0, 1, 1],
    ...                      [[[0, 0, 0], [0, 1, 0]], [[1, 0, 0], [1, 1, 0]]])
    >>> m = TriMesh([[0, 0, 0], [1, 0, 0.5], [0, 1, 0]], [[0, 1, 2]])
    >>> round(height_field_slope(m, plane).max_slope, 12)
    0.5
    """
    if metric not in ("uv", "3d"):
        raise InputError(f"metric must be 'uv' or '3d'; got {metric!r}")
    _check_mesh(mesh, "height_field_slope")
    face = as_face(target)
    used = np.unique(mesh.triangles)
    proj = project_to_face(mesh.vertices[used], face, tol_rel=tol_rel)
    n = face.surface.normals(proj.uv)
    eta_used = np.einsum("ij,ij->i", mesh.vertices[used] - proj.foot, n)
    eta = np.full(mesh.n_vertices, np.nan)
    eta[used] = eta_used
    where = np.zeros((mesh.n_vertices, 3 if metric == "3d" else 2))
    where[used] = proj.foot if metric == "3d" else proj.uv
    t = mesh.triangles
    slope = np.zeros(mesh.n_triangles)
    for i, k in ((0, 1), (1, 2), (2, 0)):
        dist = np.linalg.norm(where[t[:, i]] - where[t[:, k]], axis=1)
        diff = np.abs(eta[t[:, i]] - eta[t[:, k]])
        with np.errstate(divide="ignore", invalid="ignore"):
            s = np.where(dist > 0, diff / dist, np.where(diff > 0, np.inf, 0.0))
        slope = np.maximum(slope, s)
    finite = np.isfinite(slope)
    return HeightFieldSlope(
        max_slope=float(slope.max()),
        worst_triangle=int(np.argmax(slope)),
        p95_slope=float(np.percentile(slope, 95, method="higher")),
        max_abs_height=float(np.abs(eta_used).max()),
        metric=metric,
        per_triangle=slope,
        heights=eta,
        n_undefined=int((~finite).sum()),
    )

"""Flipped triangles: in the parameter domain and against the surface normal.

A triangle (a, b, c) that is counter-clockwise in (u, v) maps, to first order,
to a 3D triangle with normal (signed uv area) * (F_u x F_v). So on a face
whose outward normal is F_u x F_v (``same_sense``) every triangle must be
counter-clockwise in (u, v), and clockwise otherwise. Without a face, the
expected orientation is the one most triangles have.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..geom.predicates import orient2d
from ..model import TriMesh, TrimmedFace
from ._results import ResultMixin
from .deviation import _check_mesh, project_to_face
from .sampling import as_face

__all__ = ["FlippedTriangles", "flipped_triangles_uv", "flipped_triangles_normal"]


@dataclass(frozen=True, eq=False)
class FlippedTriangles(ResultMixin):
    """Triangles whose orientation disagrees with the expected one.

    Attributes
    ----------
    n_flipped : int
    flipped : (k,) int64
    n_zero : int
        Triangles of zero signed area in (u, v) ("uv") or with a normal
        perpendicular to the surface normal ("normal").
    zero : (j,) int64
    expected_sign : int
        +1 or -1: the sign of the uv area (or of the normal dot product) that is right.
    method : str
        "uv" or "normal".
    """

    n_flipped: int
    flipped: np.ndarray
    n_zero: int
    zero: np.ndarray
    expected_sign: int
    method: str


def _result(sign: np.ndarray, expected: int, method: str) -> FlippedTriangles:
    flipped = np.flatnonzero(sign == -expected).astype(np.int64)
    zero = np.flatnonzero(sign == 0).astype(np.int64)
    return FlippedTriangles(int(len(flipped)), flipped, int(len(zero)), zero, int(expected), method)


def flipped_triangles_uv(mesh: TriMesh, *, uv=None, face: TrimmedFace | None = None) -> FlippedTriangles:
    """Triangles whose signed area in the parameter domain has the wrong sign.

    Parameters
    ----------
    mesh : TriMesh
    uv : (n, 2) float64 or None
        Parameters of the vertices; default `mesh.uv`.
    face : TrimmedFace or None
        When given, the expected sign is +1 if `face.same_sense` else -1;
        otherwise the sign of the majority of triangles (ties: +1).

    Returns
    -------
    FlippedTriangles
        The sign is exact (`geom.orient2d`, adaptive precision).

    Raises
    ------
    InputError
        No uv available or uv of the wrong shape.

    Examples
    --------
    >>> m = TriMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], [[0, 1, 2], [1, 2, 3]],
    ...             uv=[[0, 0], [1, 0], [0, 1], [1, 1]])
    >>> flipped_triangles_uv(m).flipped.tolist()  # a tie: +1 expected
    [1]
    """
    _check_mesh(mesh, "flipped_triangles_uv")
    uv = mesh.uv if uv is None else np.asarray(uv, dtype=np.float64)
    if uv is None:
        raise InputError("flipped_triangles_uv: mesh has no uv and none was given")
    if uv.shape != (mesh.n_vertices, 2):
        raise InputError(f"uv must have shape ({mesh.n_vertices}, 2); got {uv.shape}")
    t = mesh.triangles
    sign = orient2d(uv[t[:, 0]], uv[t[:, 1]], uv[t[:, 2]])
    if face is not None:
        if not isinstance(face, TrimmedFace):
            raise InputError(f"face must be a TrimmedFace; got {type(face).__name__}")
        expected = 1 if face.same_sense else -1
    else:
        expected = 1 if np.count_nonzero(sign > 0) >= np.count_nonzero(sign < 0) else -1
    return _result(sign, expected, "uv")


def flipped_triangles_normal(mesh: TriMesh, target, *, tol_rel: float = 1e-10, centroid_uv=None) -> FlippedTriangles:
    """Triangles whose normal points against the surface normal at the centroid's closest point.

    Parameters
    ----------
    mesh : TriMesh
    target : NurbsSurface or TrimmedFace
        The normal is oriented by `TrimmedFace.same_sense`.
    tol_rel : float
        Projection tolerance.
    centroid_uv : (m, 2) float64, optional
        The centroids' closest points, when already projected (e.g. by
        `shell_deviation`'s samples): not projected again.

    Returns
    -------
    FlippedTriangles
        Flipped where (triangle normal) . (surface normal) < 0; `zero` lists
        zero-area triangles and those exactly perpendicular.

    Raises
    ------
    InputError
        Wrong types; MeshError for a mesh without triangles.
    """
    _check_mesh(mesh, "flipped_triangles_normal")
    face = as_face(target)
    if centroid_uv is None:
        centroids = mesh.vertices[mesh.triangles].mean(axis=1)
        centroid_uv = project_to_face(centroids, face, tol_rel=tol_rel).uv
    elif np.shape(centroid_uv) != (mesh.n_triangles, 2):
        raise InputError(f"centroid_uv must have shape ({mesh.n_triangles}, 2); got {np.shape(centroid_uv)}")
    ns = face.oriented_normals(np.asarray(centroid_uv, dtype=np.float64))
    dot = np.einsum("ij,ij->i", mesh.triangle_normals(), ns)
    sign = np.sign(np.where(np.isfinite(dot), dot, 0.0)).astype(np.int64)
    return _result(sign, 1, "normal")

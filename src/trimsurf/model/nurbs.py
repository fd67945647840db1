"""NURBS curves and surfaces: frozen containers over arrays, evaluated by `trimsurf.geom`."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import geom
from ..errors import GeometryError
from ._arrays import as_float_array

__all__ = ["NurbsCurve", "NurbsSurface"]


def _check_knots(knots: np.ndarray, degree: int, n_ctrl: int, name: str) -> None:
    if degree < 1:
        raise GeometryError(f"{name}: degree must be >= 1; got {degree}")
    if knots.shape != (n_ctrl + degree + 1,):
        raise GeometryError(
            f"{name}: need {n_ctrl + degree + 1} knots for {n_ctrl} control points of degree {degree}; "
            f"got {knots.shape[0]}")
    if np.any(np.diff(knots) < 0):
        raise GeometryError(f"{name}: knots must be non-decreasing")
    if not knots[degree] < knots[-degree - 1]:
        raise GeometryError(f"{name}: empty parameter domain [{knots[degree]}, {knots[-degree - 1]}]")


def _check_weights(weights: np.ndarray | None, shape: tuple[int, ...], name: str) -> np.ndarray | None:
    if weights is None:
        return None
    w = as_float_array(weights, f"{name}.weights")
    if w.shape != shape:
        raise GeometryError(f"{name}.weights must have shape {shape}; got {w.shape}")
    if np.any(w <= 0):
        raise GeometryError(f"{name}.weights must be positive; smallest is {w.min()!r}")
    if np.all(w == 1.0):
        return None
    return w


@dataclass(frozen=True, slots=True, eq=False)
class NurbsCurve:
    """A B-spline or NURBS curve of any degree in 2D or 3D.

    Parameters
    ----------
    degree : int
        Polynomial degree p (never the order p + 1).
    knots : (n + p + 1,) float64
        Non-decreasing knot vector.
    control_points : (n, dim) float64
        Cartesian control points (not weighted).
    weights : (n,) float64 or None
        Positive weights; None (or all ones) for a polynomial B-spline.
    """

    degree: int
    knots: np.ndarray
    control_points: np.ndarray
    weights: np.ndarray | None = None

    def __post_init__(self) -> None:
        cp = as_float_array(self.control_points, "NurbsCurve.control_points", ndim=2)
        if cp.shape[1] not in (2, 3):
            raise GeometryError(f"NurbsCurve.control_points must have shape (n, 2) or (n, 3); got {cp.shape}")
        kn = as_float_array(self.knots, "NurbsCurve.knots", ndim=1)
        degree = int(self.degree)
        _check_knots(kn, degree, cp.shape[0], "NurbsCurve")
        object.__setattr__(self, "degree", degree)
        object.__setattr__(self, "control_points", cp)
        object.__setattr__(self, "knots", kn)
        object.__setattr__(self, "weights", _check_weights(self.weights, (cp.shape[0],), "NurbsCurve"))

    @property
    def dim(self) -> int:
        return int(self.control_points.shape[1])

    @property
    def n_control_points(self) -> int:
        return int(self.control_points.shape[0])

    @property
    def is_rational(self) -> bool:
        return self.weights is not None

    @property
    def domain(self) -> tuple[float, float]:
        p = self.degree
        return float(self.knots[p]), float(self.knots[-p - 1])

    def evaluate(self, t) -> np.ndarray:
        """Points C(t), shape (n, dim)."""
        return self.derivatives(t, 0)[0]

    def derivatives(self, t, n_derivs: int = 1) -> np.ndarray:
        """Derivatives d^k C / dt^k for k = 0..n_derivs, shape (n_derivs + 1, n, dim)."""
        return geom.curve_derivatives(self.degree, self.knots, self.control_points, self.weights,
                                      t, n_derivs=n_derivs)

    def reversed(self) -> "NurbsCurve":
        """The same curve traversed backwards on the mirrored knot vector."""
        a, b = self.knots[0], self.knots[-1]
        w = None if self.weights is None else self.weights[::-1]
        return NurbsCurve(self.degree, (a + b) - self.knots[::-1], self.control_points[::-1], w)


@dataclass(frozen=True, slots=True, eq=False)
class NurbsSurface:
    """A tensor-product B-spline or NURBS surface of any degrees.

    Parameters
    ----------
    degree_u, degree_v : int
        Polynomial degrees in u and v.
    knots_u : (nu + degree_u + 1,) float64
    knots_v : (nv + degree_v + 1,) float64
    control_points : (nu, nv, 3) float64
        Cartesian control points, first index along u.
    weights : (nu, nv) float64 or None
        Positive weights; None (or all ones) for a polynomial surface.
    """

    degree_u: int
    degree_v: int
    knots_u: np.ndarray
    knots_v: np.ndarray
    control_points: np.ndarray
    weights: np.ndarray | None = None

    def __post_init__(self) -> None:
        cp = as_float_array(self.control_points, "NurbsSurface.control_points", ndim=3, last=3)
        ku = as_float_array(self.knots_u, "NurbsSurface.knots_u", ndim=1)
        kv = as_float_array(self.knots_v, "NurbsSurface.knots_v", ndim=1)
        pu, pv = int(self.degree_u), int(self.degree_v)
        _check_knots(ku, pu, cp.shape[0], "NurbsSurface (u)")
        _check_knots(kv, pv, cp.shape[1], "NurbsSurface (v)")
        object.__setattr__(self, "degree_u", pu)
        object.__setattr__(self, "degree_v", pv)
        object.__setattr__(self, "control_points", cp)
        object.__setattr__(self, "knots_u", ku)
        object.__setattr__(self, "knots_v", kv)
        object.__setattr__(self, "weights", _check_weights(self.weights, cp.shape[:2], "NurbsSurface"))

    @property
    def is_rational(self) -> bool:
        return self.weights is not None

    @property
    def shape(self) -> tuple[int, int]:
        """Number of control points (nu, nv)."""
        return int(self.control_points.shape[0]), int(self.control_points.shape[1])

    @property
    def domain(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """((u0, u1), (v0, v1))."""
        pu, pv = self.degree_u, self.degree_v
        return ((float(self.knots_u[pu]), float(self.knots_u[-pu - 1])),
                (float(self.knots_v[pv]), float(self.knots_v[-pv - 1])))

    def _args(self):
        return (self.degree_u, self.degree_v, self.knots_u, self.knots_v, self.control_points, self.weights)

    def evaluate(self, uv) -> np.ndarray:
        """Points S(u, v) for `uv` of shape (n, 2); returns (n, 3)."""
        return geom.surface_points(*self._args(), uv)

    def derivatives(self, uv, n_derivs: int = 1) -> np.ndarray:
        """SKL[k, l] = d^(k+l) S / du^k dv^l for k + l <= n_derivs; shape (d+1, d+1, n, 3)."""
        return geom.surface_derivatives(*self._args(), uv, n_derivs=n_derivs)

    def normals(self, uv) -> np.ndarray:
        """Unit normals Su x Sv / |Su x Sv|, shape (n, 3) (NaN where the surface is singular)."""
        d = self.derivatives(uv, 1)
        return geom.unit_normals(d[1, 0], d[0, 1])

    def fundamental_form(self, uv) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """First fundamental form (E, F, G), each shape (n,)."""
        d = self.derivatives(uv, 1)
        return geom.first_fundamental_form(d[1, 0], d[0, 1])

    def control_bbox(self) -> tuple[np.ndarray, np.ndarray]:
        """Bounding box of the control net (contains the surface)."""
        pts = self.control_points.reshape(-1, 3)
        return pts.min(axis=0), pts.max(axis=0)

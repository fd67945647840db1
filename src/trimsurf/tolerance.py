"""One frozen tolerance object, passed as ``tol=`` (no module globals)."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

__all__ = ["Tolerance", "default_tolerance"]


@dataclass(frozen=True, slots=True)
class Tolerance:
    """Absolute tolerances in model units.

    Parameters
    ----------
    point : float
        Distance below which two points in space are the same (model units).
    parameter : float
        Distance below which two points in a parameter domain are the same.
    angle_rad : float
        Angle below which two directions are the same (radians).
    """

    point: float = 1e-7
    parameter: float = 1e-9
    angle_rad: float = 1e-6

    def __post_init__(self) -> None:
        for name in ("point", "parameter", "angle_rad"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"Tolerance.{name} must be a positive finite number; got {value!r}")

    def scaled(self, factor: float) -> "Tolerance":
        """The same tolerance with every field multiplied by `factor`."""
        return replace(self, point=self.point * factor, parameter=self.parameter * factor,
                       angle_rad=self.angle_rad * factor)


def default_tolerance(diagonal: float, *, rel_point: float = 1e-7) -> Tolerance:
    """Tolerance derived from a bounding-box diagonal (model units).

    Examples
    --------
    >>> default_tolerance(2.0)
    Tolerance(point=2e-07, parameter=1e-09, angle_rad=1e-06)
    """
    diagonal = float(diagonal)
    if not (np.isfinite(diagonal) and diagonal > 0):
        diagonal = 1.0
    return Tolerance(point=rel_point * diagonal)

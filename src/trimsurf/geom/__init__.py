"""Pure maths on numpy arrays: B-spline/NURBS curves and surfaces, Bézier patches,
closest-point projection, Whitney extension. No I/O, no model classes.

Every function is batched over many parameters at once.
"""

from .nurbs import (basis_functions, curve_derivatives, curve_points, find_spans,
                    first_fundamental_form, surface_derivatives, surface_points, unit_normals)

__all__ = ["find_spans", "basis_functions", "curve_points", "curve_derivatives", "surface_points",
           "surface_derivatives", "unit_normals", "first_fundamental_form"]

# The other submodules load on first use (module ``__getattr__``): the reader server needs only the
# B-spline evaluation above, and `predicates` pulls in scipy.spatial (~0.2-0.4 s); ``from trimsurf.geom
# import X`` works as before.
_LAZY = {
    "predicates": ("orient2d", "points_in_polygons", "polygon_signed_area", "polyline_self_intersections",
                   "segment_intersections"),
    "bezier": ("bernstein", "bernstein_derivatives", "elevate_bezier", "bezier_curve_points",
               "bezier_curve_derivatives", "bezier_patch_points", "bezier_patch_derivatives",
               "monomial_to_bezier", "bezier_to_monomial"),
    "knots": ("InsertionResult", "ElevationResult", "BezierSegments", "BezierPatches", "CurveData", "SurfaceData",
              "insert_knot", "refine_knots", "elevate_degree", "bezier_extract", "bezier_extract_surface",
              "bezier_curve_to_nurbs", "bezier_grid_to_nurbs"),
    "triangular": ("triangle_indices", "bezier_triangle_points", "bezier_triangle_derivatives",
                   "elevate_bezier_triangle"),
    "projection": ("Projection", "CurveProjection", "project_to_surface", "project_to_curve"),
    "whitney": ("WhitneyExtension", "whitney_extension", "lipschitz_constant"),
}
_HOME = {name: module for module, names in _LAZY.items() for name in names}

for _names in _LAZY.values():
    __all__ += list(_names)
del _names


def __getattr__(name: str):
    from importlib import import_module
    if name in _HOME:
        value = getattr(import_module(f".{_HOME[name]}", __name__), name)
    elif name in _LAZY:
        value = import_module(f".{name}", __name__)
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_HOME) | set(_LAZY))

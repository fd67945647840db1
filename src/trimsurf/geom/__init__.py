"""Pure maths on numpy arrays: B-spline/NURBS curves and surfaces, Bézier patches,
closest-point projection, Whitney extension. No I/O, no model classes.

Every function is batched over many parameters at once.
"""

from .nurbs import (basis_functions, curve_derivatives, curve_points, find_spans,
                    first_fundamental_form, surface_derivatives, surface_points, unit_normals)

__all__ = ["find_spans", "basis_functions", "curve_points", "curve_derivatives", "surface_points",
           "surface_derivatives", "unit_normals", "first_fundamental_form"]

from .predicates import (orient2d, points_in_polygons, polygon_signed_area, polyline_self_intersections,
                         segment_intersections)

__all__ += ["orient2d", "points_in_polygons", "polygon_signed_area", "polyline_self_intersections",
            "segment_intersections"]

from .bezier import (bernstein, bernstein_derivatives, bezier_curve_derivatives, bezier_curve_points,
                     bezier_patch_derivatives, bezier_patch_points, bezier_to_monomial, elevate_bezier,
                     monomial_to_bezier)

__all__ += ["bernstein", "bernstein_derivatives", "elevate_bezier", "bezier_curve_points",
            "bezier_curve_derivatives", "bezier_patch_points", "bezier_patch_derivatives",
            "monomial_to_bezier", "bezier_to_monomial"]

from .knots import (BezierPatches, BezierSegments, CurveData, ElevationResult, InsertionResult, SurfaceData,
                    bezier_curve_to_nurbs, bezier_extract, bezier_extract_surface, bezier_grid_to_nurbs,
                    elevate_degree, insert_knot, refine_knots)

__all__ += ["InsertionResult", "ElevationResult", "BezierSegments", "BezierPatches", "CurveData", "SurfaceData",
            "insert_knot", "refine_knots", "elevate_degree", "bezier_extract", "bezier_extract_surface",
            "bezier_curve_to_nurbs", "bezier_grid_to_nurbs"]

from .triangular import (bezier_triangle_derivatives, bezier_triangle_points, elevate_bezier_triangle,
                         triangle_indices)

__all__ += ["triangle_indices", "bezier_triangle_points", "bezier_triangle_derivatives",
            "elevate_bezier_triangle"]

from .projection import CurveProjection, Projection, project_to_curve, project_to_surface
from .whitney import WhitneyExtension, lipschitz_constant, whitney_extension

__all__ += ["Projection", "CurveProjection", "project_to_surface", "project_to_curve",
            "WhitneyExtension", "whitney_extension", "lipschitz_constant"]

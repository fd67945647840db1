"""Pictures of surface quality: reflection lines (zebra), specular highlights, curvature maps.

Offscreen PNG through pyvista/VTK (`render_png`, `render_compare_png`) and a
self-contained interactive web page (`write_html`, three.js inlined).

Zebra the way inspection viewers draw it (tessellation paper, Sec. 2.1): the
reflection vector of the view ray is computed per vertex, turned into a
stripe texture coordinate, and the rasterizer interpolates that coordinate
linearly across each triangle, so thin or badly arranged triangles show as
kinks and wiggles. ``exact=`` draws the reference from the true surface
(dense refinement in (u, v), exact normals) to tell mesh artefacts from
surface features.
"""

from ._camera import Camera, default_camera
from ._curvature import CURVATURE_KINDS, Curvatures, mesh_curvatures, surface_curvatures
from ._exact import refine_exact, subdivide, unshare_faces
from ._html import HTML_MODES, write_html
from ._render import MODES, curvature_range, render_compare_png, render_png
from ._measure import StripeStraightness, stripe_straightness
from ._notebook import report_of, report_table, repr_html
from ._shading import (HighlightOptions, ZebraOptions, auto_light, auto_stripe_count, auto_stripe_count_mesh,
                       highlight_colors, reflection_vectors, stripe_coordinates, vertex_normals)

__all__ = ["render_png", "render_compare_png", "write_html", "MODES", "HTML_MODES", "Camera", "default_camera",
           "Curvatures", "CURVATURE_KINDS", "mesh_curvatures", "surface_curvatures", "refine_exact", "subdivide",
           "unshare_faces", "curvature_range", "ZebraOptions", "HighlightOptions", "vertex_normals",
           "reflection_vectors", "stripe_coordinates", "highlight_colors", "auto_stripe_count",
           "auto_stripe_count_mesh", "auto_light", "stripe_straightness", "StripeStraightness",
           "report_of", "report_table", "repr_html"]

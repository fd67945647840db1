"""Quality metrics every capability reports: plain numbers a JSON report can hold.

Each metric returns a frozen result object with ``as_dict()`` (summary
figures; per-item arrays with ``as_dict(arrays=True)``).

========================  ====================================================
module                    metrics
========================  ====================================================
`deviation`               mesh <-> surface / face / shell / mesh distance
`normals`                 normal deviation; height-field slope (joining paper)
`angles`                  triangle angles, aspect ratios
`flips`                   flipped triangles in (u, v) and against the normal
`topology`                boundary, manifoldness, orientation, genus, welding
`intersections`           self-intersections (k-d tree candidates + exact test)
`continuity`              G0 gap and G1 normal angle across shared boundaries
`closest_point`           exact closest points on triangles and meshes
`sampling`                mesh and trimmed-domain samples
========================  ====================================================
"""

from .angles import TriangleQuality, aspect_ratios, triangle_angles, triangle_quality
from .closest_point import ClosestPoints, closest_points_on_mesh, point_segment_closest, point_triangle_closest
from .continuity import Continuity, boundary_continuity, edge_continuity, face_continuity, surface_continuity
from .deviation import Deviation, ShellDeviation, mesh_deviation, project_to_face, shell_deviation, surface_deviation
from .flips import FlippedTriangles, flipped_triangles_normal, flipped_triangles_uv
from .intersections import SelfIntersections, self_intersections, triangles_intersect
from .normals import HeightFieldSlope, NormalDeviation, height_field_slope, normal_deviation
from .sampling import (TriangleSamples, distance_outside_face, inside_face, sample_face_domain,
                       sample_triangles)
from .topology import TopologyReport, Welded, boundary_loop_count, orientation_flips, topology_report, weld_vertices

__all__ = [
    "surface_deviation", "shell_deviation", "mesh_deviation", "project_to_face", "Deviation", "ShellDeviation",
    "normal_deviation", "height_field_slope", "NormalDeviation", "HeightFieldSlope",
    "triangle_angles", "aspect_ratios", "triangle_quality", "TriangleQuality",
    "flipped_triangles_uv", "flipped_triangles_normal", "FlippedTriangles",
    "topology_report", "weld_vertices", "orientation_flips", "boundary_loop_count", "TopologyReport", "Welded",
    "self_intersections", "triangles_intersect", "SelfIntersections",
    "surface_continuity", "face_continuity", "edge_continuity", "boundary_continuity", "Continuity",
    "closest_points_on_mesh", "point_triangle_closest", "point_segment_closest", "ClosestPoints",
    "sample_triangles", "sample_face_domain", "inside_face", "distance_outside_face", "TriangleSamples",
]

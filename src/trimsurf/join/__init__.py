"""Join mesh patches along common edges without folding: Whitney-extension reprojection.

Implements join-mesh-patches-whitney.txt: the error criteria of Sec. II
(`patch_errors`), the joining algorithm of Sec. III-B (Case 1: edge curves
b_k given) and III-C (Case 2: surrogates from the mesh boundaries) with
long-edge splitting (Sec. III-D), for every pair of adjacent faces of a shell
(`join_shell`), and the naive midpoint sewing of Sec. I that the paper argues
against (`midpoint_join`).

Accuracy inside the triangles (issue 13): the paper bounds the heights at the
vertices; the strip Triangle re-meshes is also refined (Ruppert refinement with
area limits, same angle bound) until every triangle's sampled deviation from
the surface is within the deflection (`triangle_deviation`); the report gives
the output's deviation measured inside the triangles (`mesh_deviation_inside`).
The paper's real case, faces meshed independently, is `mesh_faces_independently`;
an unsewn model is sewn first (`sew_shell`).

The exact Whitney extension over a face's loops, with pruning, is
`trimsurf.geom.whitney.whitney_average`: the same suprema/infima as every
(query, segment) pair, at a fraction of the paper's n x sigma cost.
"""

from ._baseline import BaselineResult, midpoint_join
from ._metrics import PatchErrors, corner_slopes, patch_errors
from ._patch import PAPER_BOUNDARY_ANGLE_DEG, PAPER_MIN_ANGLE_DEG, PatchResult
from ._accuracy import input_deviation, mesh_deviation_inside, triangle_deviation
from ._sew import mesh_faces_independently, needs_sewing, sew_shell
from ._shell import FaceReport, JoinResult, join_shell

__all__ = ["join_shell", "JoinResult", "FaceReport", "PatchResult", "midpoint_join", "BaselineResult", "patch_errors",
           "PatchErrors", "corner_slopes", "inclination_bound", "PAPER_MIN_ANGLE_DEG",
           "PAPER_BOUNDARY_ANGLE_DEG", "mesh_faces_independently", "sew_shell", "needs_sewing", "input_deviation",
           "mesh_deviation_inside", "triangle_deviation"]


def inclination_bound(lipschitz: float, min_angle_deg: float = PAPER_MIN_ANGLE_DEG) -> float:
    """Sec. III-D: lower bound of cos(inclination) of a reprojected triangle with (u, v) angles >= min_angle.

    ``((1 + L^2) (1 + (2 L / sin(min_angle))^2))^(-1/2)``.

    Examples
    --------
    >>> round(inclination_bound(0.0), 12)
    1.0
    """
    import math
    s = math.sin(math.radians(min_angle_deg))
    return 1.0 / math.sqrt((1.0 + lipschitz ** 2) * (1.0 + (2.0 * lipschitz / s) ** 2))

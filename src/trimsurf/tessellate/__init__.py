"""Tessellation of trimmed B-reps into regular, low-count meshes (Sußner, Greiner, Grosso).

One module per stage of the paper (``../shared/papers/tessellation-reflection-lines.txt``):

==============  ==========================================================================
module          stage
==============  ==========================================================================
`repair`        CAD repair: trim gaps joined, suit-case corners filled, self-crossing trims
                cut, non-G1 surfaces flagged (Sec. 4.1)
`domain`        adaptive domain values: iso-lines nearly equidistant in 3D, the paper's
                bisection, equidistribution, and the uniform baseline (Sec. 4.2, 3.4, 5.1)
`trims`         trim polygons to the 3D criteria, iso-values inserted, polygon reduction (4.3)
`grid`          Cohen-Sutherland clip, constrained Delaunay (Triangle) of crossed cells only,
                best-diagonal split or quads of untouched cells (4.3, 5.1, Fig. 10)
`pslg`          Triangle's input made one it always finishes on: near-duplicate points merged,
                segments split at points on them and at crossings (exact orient2d)
`slivers`       boundary-only reduction of thin triangles at the trims (5.1)
`common`        common parameterization of faces meeting along iso-lines (Fig. 12; opt-in)
`stitch`        stitching with a k-d tree, projection, T-junction split, check-back (4.4, 5.2)
`orient`        orientation fixing across faces (4.5, 5.3)
`seams`         seam reduction by edge collapse within the tolerance (4.6, 5.4)
`face`          one face: `tessellate_face`
`shell`         a shell: `tessellate_shell` (conforming along shared B-rep edges, or loose)
`measure`       the guarantees, measured with `trimsurf.quality`
==============  ==========================================================================
"""

from .domain import adaptive_values
from .face import tessellate_face
from .orient import orient_meshes
from .repair import repair_face
from .seams import reduce_seams
from .shell import FaceStatus, TessellationResult, default_parameters, tessellate_shell
from .stitch import stitch_mesh

__all__ = ["tessellate_face", "tessellate_shell", "TessellationResult", "FaceStatus", "default_parameters",
           "adaptive_values", "repair_face", "stitch_mesh", "orient_meshes", "reduce_seams"]

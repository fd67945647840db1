"""Certify trimmed B-reps: Whitney perturbation, normal bounds, no extraneous intersections.

The method of whitney-well-definition.txt (with the Whitney sections of
join-mesh-patches-whitney.txt):

* `sample_boundaries` - the vector boundary discrepancy eps = b_k - F of every
  face, b_k paired with its closest point on the surface (or of the trim curve,
  or at the same parameter), sampled per edge (shared parameters on both faces)
  until the per-component Lipschitz constants L stop changing and a rigorous
  bound of the gap between the perturbed faces of each shared edge is below the
  point tolerance (`trimsurf.certify._gap`); L is exact for the sampled data;
* `PerturbedFace` - G = F + a, a the componentwise Whitney average (eqs. 3-5),
  evaluable anywhere, |a_i| <= max |eps_i|, G = b_k at every sample;
* `normal_angle_bound` - the bound of Sec. 4 on the angle between the normals
  of F and G, in a corrected, rigorous form (derivation in `trimsurf.certify._normal`),
  bounded over whole faces from the Bézier control nets (`trimsurf.certify._face`);
* `certify_shell` - all of the above per face, the Volino-Thalmann test for
  extraneous intersections (pairs of faces and each face with itself), the
  well-defined (watertight by construction) mesh and its independent check;
* `loop_subdivide`, `certify_subdivision` - combined subdivision with trimming (Sec. 3.2):
  Loop subdivision with a boundary curve, stopped after finitely many levels,
  certified through the same Whitney extension and normal bound.
"""

from ._boundary import BoundaryLoop, FaceBoundary, sample_boundaries
from ._certify import PairCertificate, ShellCertificate, certify_shell, perturb_shell
from ._face import FaceCertificate
from ._normal import NormalBound, first_order_cos_bound, normal_angle_bound, printed_cos_bound
from ._perturb import PerturbedFace
from ._tolerance import file_point_tolerance
from ._subdivision import (PiecewiseLinearSurface, SubdivisionFace, SubdivisionPatch, certify_subdivision,
                           loop_subdivide, subdivision_boundary)

__all__ = ["certify_shell", "perturb_shell", "ShellCertificate", "FaceCertificate", "PairCertificate",
           "PerturbedFace", "sample_boundaries", "FaceBoundary", "BoundaryLoop",
           "normal_angle_bound", "NormalBound", "printed_cos_bound", "first_order_cos_bound",
           "SubdivisionPatch", "loop_subdivide", "subdivision_boundary", "PiecewiseLinearSurface", "SubdivisionFace",
           "certify_subdivision", "file_point_tolerance"]

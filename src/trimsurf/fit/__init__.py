"""Fit a trimmed NURBS face to a triangle mesh with holes (manifold learning + RBF + NURBS).

The method of ``mesh-to-trimmed-nurbs-face.txt`` (Ruiz et al., Int J Interact
Des Manuf 9 (2015) 303-316), Fig. 2:

1. `mesh_brep`: the boundary loops Gamma_i of M; non-manifold and
   non-disk-like meshes are rejected (`trimsurf.errors.InputError`).
2. `embed`: a forward map phi: M -> R^2 -- ``hlle`` (Hessian LLE, Donoho &
   Grimes), ``isomap`` (Dijkstra geodesics + classical / landmark MDS),
   ``laplacian`` (Laplacian Eigenmaps), and beyond the paper ``lscm`` and
   ``harmonic`` (libigl); `embedding_quality` counts folds and border crossings.
3. `parameter_grid`: the rectangular grid W covering phi(M).
4. `backmap`: S by ``nurbs`` (iterative extrapolation), ``rbf`` (thin-plate
   splines), ``hybrid`` (RBF control polyhedron + NURBS), and beyond the
   paper ``greville`` (the RBF at the Greville abscissae) and ``lsq``
   (least squares on the mesh and the RBF extrapolation; the default).
5. `trim_loops`: p-curves lambda_i of the loops in S's domain.

`fit_trimmed_face` runs all of it and returns a `FitResult` whose ``face``
is a `trimsurf.model.TrimmedFace` (write it with ``trimsurf.io.write_shell``).
`measure_written_face` reads the written STEP file back through Open CASCADE
and measures the face as read (Hausdorff both ways inside the trims, area,
BRepCheck, self-intersections): the figures to report. `fit_quality` is an
in-memory diagnostic (S on the mesh's parameter triangulation, no trims).
"""

from ._backmap import BACKMAPS, BackMap, backmap, greville_hybrid, hybrid, lsq_fit, nurbs_extrapolation, rbf_map
from ._brep import MeshBRep, angle_defects, mesh_brep, vertex_areas
from ._embed import (DEVELOPABLE_LIMIT, EMBEDDINGS, EmbeddingQuality, boundary_crossings, embed, embedding_quality,
                     harmonic, hessian_lle, hessian_matrix, isomap, laplacian_eigenmaps, lscm, normalize_parameters)
from ._fit import FitQuality, FitResult, evaluated_face_mesh, fit_quality, fit_trimmed_face
from ._grid import ParameterGrid, locate, parameter_grid
from ._measure import WrittenFace, deflection_for, measure_written_face
from ._trim import order_loops, trim_loops

__all__ = ["mesh_brep", "MeshBRep", "angle_defects", "vertex_areas",
           "embed", "EMBEDDINGS", "DEVELOPABLE_LIMIT", "hessian_lle", "hessian_matrix", "isomap",
           "laplacian_eigenmaps", "lscm", "harmonic", "normalize_parameters", "embedding_quality",
           "EmbeddingQuality", "boundary_crossings",
           "parameter_grid", "ParameterGrid", "locate",
           "backmap", "BACKMAPS", "BackMap", "hybrid", "greville_hybrid", "lsq_fit", "nurbs_extrapolation", "rbf_map",
           "order_loops", "trim_loops",
           "fit_trimmed_face", "FitResult", "fit_quality", "FitQuality", "evaluated_face_mesh",
           "measure_written_face", "WrittenFace", "deflection_for"]

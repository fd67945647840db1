"""Smooth G1 surfaces through the vertices of triangle meshes, from G1 or G2 minimum norm networks.

The method of Kolb, Pottmann and Seidel, *Surface reconstruction based upon minimum norm
networks* (``../shared/papers/mnn-surface-reconstruction.txt``):

1. vertex normals and local frames (`vertex_normals`, `local_frames`);
2. a curve network over the mesh edges whose curves depend linearly on unknown
   surface derivatives at the vertices, optimized by one sparse solve per normal
   update (`build_network`: cubic G1, quintic G2 with a cross-boundary vector
   field, or the Shirman-Séquin baseline);
3. triangular Bézier patches filling the network (`fill_split_quartic`,
   `fill_peters_quintic`, `fill_single_quintic`, `fill_split_sextic`, `fill_single_septic`);
   the G2 networks are filled to G1 surfaces too (paper, section 6);
4. `reconstruct_mesh` runs all three and reports the figures.

Examples
--------
>>> from trimsurf.samples import octahedron
>>> from trimsurf.reconstruct import reconstruct_mesh
>>> rec = reconstruct_mesh(octahedron(), network="g1", fill="split")
>>> rec.report["g1_angle_max_deg"] < 1e-6
True
"""

from .api import FILLS, Reconstruction, radial_deviation, reconstruct_mesh, sphere_fit, vertex_interpolation_error
from .export import patches_to_shell, triangle_to_tensor
from .fill import (FacetPatches, fill_single_quintic, fill_single_septic, fill_split_quartic,
                   fill_split_sextic)
from .peters import fill_peters_quintic
from .network import DIRECTIONS, FUNCTIONALS, LENGTHS, NETWORKS, SECONDS, CurveNetwork, build_network, curve_parameters
from .normals import NORMAL_WEIGHTS, local_frames, normal_curvature_forms, vertex_normals
from .surface import PatchSet, g1_continuity, grid_bary, load_patches, save_patches
from ._topology import MeshTopology, mesh_topology

__all__ = ["reconstruct_mesh", "Reconstruction", "FILLS", "build_network", "CurveNetwork", "curve_parameters",
           "NETWORKS", "DIRECTIONS", "LENGTHS", "FUNCTIONALS", "SECONDS", "vertex_normals", "local_frames",
           "normal_curvature_forms", "NORMAL_WEIGHTS", "fill_split_quartic", "fill_single_quintic",
           "fill_peters_quintic",
           "fill_split_sextic", "fill_single_septic", "FacetPatches", "PatchSet", "g1_continuity", "grid_bary",
           "save_patches", "load_patches", "vertex_interpolation_error", "sphere_fit", "radial_deviation",
           "mesh_topology", "MeshTopology", "patches_to_shell", "triangle_to_tensor"]

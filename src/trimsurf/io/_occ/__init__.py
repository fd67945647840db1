"""Open CASCADE shapes <-> trimsurf models, shared by the STEP and IGES readers and the STEP writer.

Reading
-------
A file is read with Open CASCADE's reader, the whole shape is converted with
``BRepBuilderAPI_NurbsConvert`` (so every surface and its p-curves become
B-splines with one consistent parameterization: analytic surfaces get Open
CASCADE's own conversion) and every face becomes a `TrimmedFace`:

* surface: the face's ``Geom_BSplineSurface`` (location applied), knots with
  their multiplicities expanded, periodic directions made non-periodic;
* loops: ``BRepTools_WireExplorer`` over the wires of the face taken FORWARD,
  outer wire (``BRepTools::OuterWire``) first, holes after. Open CASCADE keeps
  the material on the left of a FORWARD face's wires in (u, v), so outer loops
  come out counter-clockwise and holes clockwise for every face; the face's
  own orientation goes to ``TrimmedFace.same_sense`` (REVERSED -> False: the
  outward normal is -(Su x Sv));
* segments: one `PCurve` per oriented edge, ``t0, t1`` the edge range, swapped
  (t0 > t1) for a REVERSED edge; ``edge_curve`` the edge's 3D B-spline b(t) on
  the same parameter; ``edge_id`` the index in ``Shell.edges``. A seam edge is
  used twice by its face, once per orientation, each with its own p-curve.

Conventions decided here (measured on ``../shared/data/cad``):

* Domain coverage. Open CASCADE evaluates a non-periodic B-spline outside its
  knot range by continuing the end polynomials, and p-curves of real files
  leave the domain (up to 1.5 % of it on gmsh__SampleCrankshaft4A, 0.7 % on
  occt__bearing.iges). trimsurf clamps instead, so where a face's p-curves or
  UV bounds leave the surface domain the end span is extended exactly: knot
  ``a`` before the end is raised to multiplicity p (Open CASCADE knot
  insertion) and the end span's Bézier points are continued by de Casteljau
  extrapolation in homogeneous coordinates. The surface is the same
  (rational) polynomial on a larger domain, with a margin of 1e-6 of the
  domain beyond the farthest sampled p-curve point.
* Periodic seam. A periodic direction is made non-periodic with
  ``SetUNotPeriodic``/``SetVNotPeriodic``, which keeps the knot span
  [k0, k0 + T]. When a face's (u, v) range leaves that span (a face crossing
  the seam), a knot is inserted at the face's lower bound (shifted by whole
  periods into the span), made the origin with ``SetUOrigin``/``SetVOrigin``,
  and the knot vector is translated by the whole periods, so the surface
  domain is [lower bound, lower bound + T] and the p-curves stay as they are.
  None of the faces of the shared data needs it; the tests build one.
* Edge tolerance. ``Edge.tolerance`` is Open CASCADE's tolerance, raised to
  the same-parameter deviation max |S(p(t)) - b(t)| measured by
  ``BRepLib_ValidateEdge`` (47 points per edge and face) where the file's
  curves disagree by more than they state, as ``BRepLib::SameParameter``
  would. gmsh__t20_data (26 of 48 edges, up to 5e-5 of the diagonal) and
  occt__linkrods (8 of 108) need it most: their p-curves lie on the 3D curves
  geometrically but with another parameterization; occtpr946__ec_soapbox-A,
  occtpr946__trj5_k1-pe-214, occtpr946__bug27693_cornetta and
  occt__bearing have a few edges raised by less than 4x.
* Domain extension happens on 279 faces of the shared data, most by tiny
  amounts; it is refused when the extrapolated weights of a rational surface
  would not stay positive (the domain is then kept and evaluation outside it
  clamps), which no face of the shared data needs.

Open CASCADE prints to stdout/stderr on bad files; every call into it here
runs with file descriptors 1 and 2 redirected into a temporary file (the text
is used for the one-line error message). The redirection is process-wide, so
do not read CAD files from several threads at once.

Hostile files. ``trimsurf.io.read_shell`` reads STEP and IGES files in a
child process with a time limit (`_isolate`, `_worker`), so a crash or a hang
of Open CASCADE is a one-line error naming the file. Before Open CASCADE
transfers anything, a file holding a number that is not finite or above 1e10
in magnitude is refused (`_checks.check_file_numbers`: a pole of 250.E+999
made the transfer spin), and so is a STEP file whose records the parser flags
as "Incorrect Syntax" (transferring them can crash the process); after the
transfer every face's surface, curves and vertices are checked the same way
(`_checks.check_shape_geometry`). A face that cannot be converted is left
out with a `FaceSkippedWarning` naming it, never the whole file.

Modules: `_read` (quiet reading, B-spline conversion), `_geometry` (curves and
surfaces both ways), `_to_shell` (shape -> Shell), `_to_shape` (Shell -> shape),
`_checks` (finite-geometry checks), `_isolate` / `_worker` (the child process; the server that forks it
is managed by `trimsurf.io._server`, which the ``trimsurf`` command starts first thing).
"""

from __future__ import annotations

from .. import check_readable as check_file
from ._geometry import (
    _array1_double,  # noqa: F401  (tests build Open CASCADE knot arrays with it)
    curve_from_occ,
    curve_to_occ,
    surface_from_occ,
    surface_to_occ,
)
from ._read import (
    _occ_detail,  # noqa: F401  (the STEP writer reuses Open CASCADE's message)
    count_faces,
    invalid_faces,
    nurbs_shape,
    quiet_occ,
    read_shape,
)
from ._isolate import read_isolated
from ._to_shape import compound, shell_to_shape
from ._to_shell import OccTopology, map_topology, shape_to_shell

__all__ = ["quiet_occ", "read_shape", "nurbs_shape", "map_topology", "OccTopology", "shape_to_shell",
           "shell_to_shape", "compound", "count_faces", "curve_from_occ", "curve_to_occ",
           "surface_from_occ", "surface_to_occ", "check_file", "invalid_faces", "read_isolated"]

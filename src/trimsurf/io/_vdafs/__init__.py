"""The VDA-FS 2.0 subset of the tessellation paper (SURF, CURVE, CONS, FACE), read and written by hand.

No maintained library reads VDA-FS (DIN 66301), so this module implements the
part of it that carries trimmed surfaces: polynomial patch surfaces (SURF),
3D curves (CURVE), curves on surfaces given in the surface's parameters (CONS)
and trimmed faces (FACE).

File layout (as reconstructed; see Notes for the sources)
-----------------------------------------------------------
* Records of at most 80 columns: columns 1-72 hold statement text, columns
  73-80 a sequence field (a record number or name, ignored on reading).
  Trailing blanks may be missing; a record longer than 80 columns, or a
  sequence field holding statement characters (``, = /``), is an error.
* ``$$`` starts a comment that runs to column 72.
* A statement is ``name = KEYWORD / p1, p2, ...``; it continues on the next
  record while its text ends with a comma (or with the ``/``). Names have at
  most 8 characters (letters, digits, ``_``).
* The first statement is ``name = HEADER / n``; the n records after it are free
  text. The last statement is ``name = END``. ``BEGINSET`` / ``ENDSET`` bracket
  sets and must balance.
* Numbers are Fortran-like: ``2``, ``2.``, ``-.5``, ``1.0E+01``, ``1.D0``.

Entities (parameter order)::

    name = SURF  / nps, npt, s(1..nps+1), t(1..npt+1),
                   { iords, iordt, ax(iords*iordt), ay(...), az(...) }  nps*npt times
    name = CURVE / n, par(1..n+1), { iord, ax(iord), ay(iord), az(iord) }  n times
    name = CONS  / surf, curve, s1, s2, n, par(1..n+1), { iord, as(iord), at(iord) }  n times
    name = FACE  / surf, m, { k, (cons, w1, w2) k times }  m times

* Each patch or segment is a polynomial in **monomial (power) form** over its
  local parameter normalised to [0, 1]: for the patch (i, j) of a SURF,
  ``x(s, t) = sum_k sum_l ax(k, l) u**(k-1) v**(l-1)`` with
  ``u = (s - s_i) / (s_{i+1} - s_i)`` and ``v = (t - t_j) / (t_{j+1} - t_j)``.
  The coefficient arrays are stored in Fortran order, the u-power running
  fastest, first all x, then all y, then all z. Patches are listed with the
  s-index running fastest (row t_1 first).
* A CONS is a 2D curve in the (s, t) parameters of its SURF; its own
  parameter w runs over [par(1), par(n+1)] and maps linearly onto the 3D
  CURVE's parameter range [s1, s2] (s1 > s2 when the CURVE runs the other
  way). The CURVE name may be left empty when there is no 3D curve.
* A FACE lists its trim loops, the outer boundary first, each as a chain of
  CONS used from w1 to w2 (w1 > w2: against the CONS's direction).

What the reader returns
-----------------------
A :class:`~trimsurf.model.Shell` without edges (VDA-FS carries no topology).
Every FACE becomes a :class:`~trimsurf.model.TrimmedFace` named after it;
every SURF no FACE refers to becomes an untrimmed face named after the SURF.
Each SURF becomes one polynomial B-spline surface: patches of lower order are
raised to the surface's highest order in u and in v (the paper's rule), and
the breakpoints become knots of multiplicity degree. Each CONS becomes the
2D :class:`~trimsurf.model.NurbsCurve` of a :class:`~trimsurf.model.PCurve`
with C0 joints, its CURVE (re-parameterised onto w) the p-curve's edge curve.

Defects of real data (the paper, section 4.1: CATIA exports trim loops that
are not closed and omits CONS of zero 3D length) are reported, not repaired:
a trim loop with a gap, a CONS whose segments do not meet and a SURF whose
patches do not meet are read with a :class:`~trimsurf.errors.TrimsurfWarning`
naming the entity and the gap. Each SURF's surface is a ``PatchGridSurface``
carrying the reader's ``PatchGrid`` (its breakpoints as read and the gap
between the shared boundary control points of every pair of adjacent
patches): a SURF whose patches do not meet (their boundary rows are averaged)
or whose breakpoints do not increase strictly (replaced by 0, 1, 2, ...) is
still read, and `trimsurf.tessellate.repair` rejects the faces that use the
broken part by name, so the rest of the file is tessellated. References to
missing entities, malformed numbers, truncated statements and broken records
raise :class:`~trimsurf.errors.VdafsReadError` naming the file, line and entity.

Exactness
---------
Monomial and Bernstein (Bezier) coefficients are converted in exact rational
arithmetic (Python integers): the reader parses each decimal number exactly
and rounds each control point once, to the nearest float. The writer computes
the exact monomial coefficients of each Bezier patch and writes them with the
fewest significant digits (17, then more, at most 60) for which this reader
gets back the same floats. Hence

* write -> read returns the written Bezier control points bit for bit (a
  surface given as a grid of Bezier patches with knots of multiplicity degree
  comes back with identical knots and control points; other B-splines come
  back as their Bezier extraction, equal as surfaces to rounding), and
* read -> write -> read returns the first read bit for bit.

(-0.0 reads back as 0.0.) A reader that converts in floating point is off
by up to about ``3**(du + dv)`` ulps of the patch's largest control point:
harmless for bicubic patches, but for the order-20 patches of real car data
(the paper, section 4.1) a float64 Bezier -> monomial -> Bezier round trip was
measured to lose all digits (relative error 0.87 for a random degree 19 x 19
patch), hence the exact arithmetic. Cost, measured: about 0.3 ms per bicubic
patch to read and 0.75 ms to write; 0.1 s for one degree 19 x 19 patch.

Notes
-----
The layout follows the statement form and entity list of VDA-FS 2.0
(DIN 66301; Autodesk Alias and TechSoft HOOPS documentation list SURF, CONS,
FACE as "Surface", "Curve on surface", "Bounded surface"). The parameter order
and the monomial convention were checked against data: the DIN 66301 example
surface FLAE0001 (a 1 x 2 patch SURF with orders 3 x 4 and 3 x 3; its
patches meet only with the u-power running fastest), a SolidWorks VDA-FS
export with CURVE, CONS and FACE (segments meet only with the local
parameter normalised to [0, 1]; a reversed CONS has s1 > s2 and a 2D
parameter running over the negated range), both in the OpenVDAFS project
(github.com/chiefenne/OpenVDAFS, examples/), and against the VDA-FS reader
of the VARKON library (sources/GE/src/sur550.c, sur557.c: patch order with
IU fastest; coefficients x, y, z, each with the u-power fastest).

Files whose statement text runs past column 72 (the SolidWorks export above
writes free-format records without sequence field) are rejected with a
message naming the record, not guessed at.

References
----------
.. [1] DIN 66301 / VDA-FS Version 2.0, Verband der Automobilindustrie, 1987.
.. [2] "Generating high quality meshes for interactive examination of surface
   quality on car bodies" (``tessellation-reflection-lines.txt``), section 4.1.
"""

from ._reader import PatchGrid, PatchGridSurface, read
from ._writer import write

__all__ = ["read", "write", "PatchGrid", "PatchGridSurface"]

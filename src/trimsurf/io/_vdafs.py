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
naming the entity and the gap. References to missing entities, malformed
numbers, truncated statements and broken records raise
:class:`~trimsurf.errors.VdafsReadError` naming the file, line and entity.

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

from __future__ import annotations

import math
import os
import re
import warnings
from dataclasses import dataclass
from decimal import ROUND_HALF_EVEN, Context, Decimal
from functools import lru_cache
from pathlib import Path

import numpy as np

from ..errors import GeometryError, InputError, TrimsurfWarning, VdafsReadError
from ..geom.predicates import points_in_polygons, polygon_signed_area
from ..geom.knots import bezier_curve_to_nurbs, bezier_extract, bezier_extract_surface, bezier_grid_to_nurbs
from ..model import Loop, NurbsCurve, NurbsSurface, PCurve, Shell, TrimmedFace
from ..tolerance import Tolerance, default_tolerance
from ._atomic import atomic_path

__all__ = ["read", "write"]

_RECORD_COLS = 80
_TEXT_COLS = 72
_NAME_MAX = 8
# significant digits the writer tries, in turn, until the reader gets back the same floats
_DIGIT_STEPS = (17, 20, 24, 30, 40, 50, 60)

_NAME_RE = re.compile(r"[A-Za-z0-9_]+\Z")
_STATEMENT_RE = re.compile(r"\s*([^\s=]+)\s*=\s*([A-Za-z$]+)\s*(?:/(.*))?\Z")
_NUMBER_RE = re.compile(r"([+-]?)(\d*)(?:\.(\d*))?(?:[EeDd]([+-]?\d+))?\Z")
# samples per CONS when a trim loop's sense and containment are measured
_ORIENT_SAMPLES = 32
_SKIPPED = frozenset({"POINT", "PSET", "MDI", "CIRCLE", "TOP", "GROUP", "SET", "TMAT", "TLIST"})


# ----------------------------------------------------------------------------------------------
# exact monomial <-> Bernstein conversion (Python integers in numpy object arrays)
# ----------------------------------------------------------------------------------------------

@lru_cache(maxsize=None)
def _power_to_bernstein(degree: int) -> tuple[np.ndarray, int]:
    """Integer matrix P and scale L with b = (P @ a) / L for monomials a on [0, 1].

    ``b_i = sum_{j <= i} C(i, j) / C(n, j) a_j`` (Farin, Curves and Surfaces for
    CAGD, ch. 5, monomial to Bernstein form).
    """
    n = degree
    scale = math.lcm(*(math.comb(n, j) for j in range(n + 1)))
    mat = np.zeros((n + 1, n + 1), dtype=object)
    for i in range(n + 1):
        for j in range(i + 1):
            mat[i, j] = math.comb(i, j) * (scale // math.comb(n, j))
    return mat, scale


@lru_cache(maxsize=None)
def _bernstein_to_power(degree: int) -> np.ndarray:
    """Integer matrix Q with a = Q @ b: ``a_j = C(n, j) sum_{i <= j} (-1)**(j - i) C(j, i) b_i``."""
    n = degree
    mat = np.zeros((n + 1, n + 1), dtype=object)
    for j in range(n + 1):
        for i in range(n + 1):
            mat[j, i] = math.comb(n, j) * math.comb(j, i) * (-1) ** (j - i) if i <= j else 0
    return mat


def _scaled_ints(values: list[tuple[int, int]], shape: tuple[int, ...]) -> tuple[np.ndarray, int]:
    """Exact decimals (mantissa, exponent) -> integer array M and exponent E with value = M * 10**E."""
    exp = min((e for m, e in values if m), default=0)
    arr = np.empty(len(values), dtype=object)
    arr[:] = [m * 10 ** (e - exp) if m else 0 for m, e in values]
    return arr.reshape(shape), exp


def _divide(num: np.ndarray, den: int) -> np.ndarray:
    """Correctly rounded float64 of num / den for an object array of Python ints."""
    return np.array([n / den for n in num.ravel()], dtype=np.float64).reshape(num.shape)


def _power_patch_to_bezier(coeffs: list[list[tuple[int, int]]], orders: tuple[int, int],
                           degrees: tuple[int, int]) -> np.ndarray:
    """Exact monomial patch (per coordinate, u-power fastest) -> Bezier control points (du+1, dv+1, dim)."""
    ou, ov = orders
    pu, lu = _power_to_bernstein(degrees[0])
    pv, lv = _power_to_bernstein(degrees[1])
    out = np.empty((degrees[0] + 1, degrees[1] + 1, len(coeffs)))
    for c, values in enumerate(coeffs):
        a, exp = _scaled_ints(values, (ov, ou))
        num = pu[:, :ou] @ a.T @ pv[:, :ov].T
        den = lu * lv
        if exp >= 0:
            num = num * 10 ** exp
        else:
            den *= 10 ** (-exp)
        out[:, :, c] = _divide(num, den)
    return out


def _power_segment_to_bezier(coeffs: list[list[tuple[int, int]]], order: int, degree: int) -> np.ndarray:
    """Exact monomial curve segment (per coordinate) -> Bezier control points (degree+1, dim)."""
    pm, scale = _power_to_bernstein(degree)
    out = np.empty((degree + 1, len(coeffs)))
    for c, values in enumerate(coeffs):
        a, exp = _scaled_ints(values, (order,))
        num = pm[:, :order] @ a
        den = scale
        if exp >= 0:
            num = num * 10 ** exp
        else:
            den *= 10 ** (-exp)
        out[:, c] = _divide(num, den)
    return out


def _float_ints(values: np.ndarray) -> tuple[np.ndarray, int]:
    """Floats -> integer object array N and k with values = N / 2**k exactly."""
    ratios = [float(v).as_integer_ratio() for v in values.ravel()]
    k = max(d.bit_length() - 1 for _, d in ratios)
    arr = np.empty(len(ratios), dtype=object)
    arr[:] = [n << (k - (d.bit_length() - 1)) for n, d in ratios]
    return arr.reshape(values.shape), k


def _exact_power_patch(bezier: np.ndarray) -> list[tuple[np.ndarray, int]]:
    """Bezier patch (du+1, dv+1, dim) -> per coordinate the exact monomials (N, k): a = N / 2**k."""
    qu = _bernstein_to_power(bezier.shape[0] - 1)
    qv = _bernstein_to_power(bezier.shape[1] - 1)
    out = []
    for c in range(bezier.shape[2]):
        b, k = _float_ints(bezier[:, :, c])
        out.append((qu @ b @ qv.T, k))
    return out


def _exact_power_segment(bezier: np.ndarray) -> list[tuple[np.ndarray, int]]:
    """Bezier segment (p+1, dim) -> per coordinate the exact monomials (N, k): a = N / 2**k."""
    q = _bernstein_to_power(bezier.shape[0] - 1)
    out = []
    for c in range(bezier.shape[1]):
        b, k = _float_ints(bezier[:, c])
        out.append((q @ b, k))
    return out


def _format_decimal(d: Decimal) -> str:
    """A Decimal in Fortran E form, e.g. ``-1.25E+02``; zero as ``0.0``."""
    sign, digits, exponent = d.as_tuple()
    if not any(digits):
        return "0.0"
    text = "".join(map(str, digits)).rstrip("0") or "0"
    exp10 = exponent + len(digits) - 1
    mantissa = text[0] + "." + (text[1:] or "0")
    return f"{'-' if sign else ''}{mantissa}E{exp10:+03d}"


def _format_float(x: float) -> str:
    """Shortest decimal that reads back as the float `x` (Python repr digits), in Fortran E form."""
    return _format_decimal(Decimal(repr(float(x))))


@lru_cache(maxsize=None)
def _context(digits: int) -> Context:
    return Context(prec=digits, rounding=ROUND_HALF_EVEN, Emax=10 ** 6, Emin=-10 ** 6)


def _round_exact(num: int, k: int, digits: int) -> Decimal:
    """num / 2**k correctly rounded to `digits` significant decimal digits."""
    return _context(digits).divide(Decimal(num), Decimal(1 << k))


def _decimal_pair(d: Decimal) -> tuple[int, int]:
    """A finite Decimal -> (mantissa, exponent) with value mantissa * 10**exponent."""
    sign, digits, exponent = d.as_tuple()
    mantissa = int("".join(map(str, digits)) or "0")
    return (-mantissa if sign else mantissa), int(exponent)


def _parse_exact(text: str) -> tuple[int, int] | None:
    """A Fortran-like number -> (mantissa, exponent) with value mantissa * 10**exponent; None if malformed."""
    m = _NUMBER_RE.match(text)
    if m is None:
        return None
    sign, whole, frac, exp = m.groups()
    frac = frac or ""
    if not whole and not frac:
        return None
    mantissa = int(whole + frac or "0")
    return (-mantissa if sign == "-" else mantissa), int(exp or 0) - len(frac)


def _patch_power_tokens(bezier: np.ndarray) -> tuple[tuple[int, int], list[str]]:
    """Orders and coefficient strings (x, y, z blocks, u-power fastest) of a Bezier patch.

    Trailing monomial orders whose coefficients are exactly zero are dropped;
    the digits are raised until the exact re-conversion gives back `bezier`.
    """
    exact = _exact_power_patch(bezier)
    nz_u = [j for j in range(bezier.shape[0]) if any(np.any(n[j, :] != 0) for n, _ in exact)]
    nz_v = [j for j in range(bezier.shape[1]) if any(np.any(n[:, j] != 0) for n, _ in exact)]
    ou = max(nz_u, default=0) + 1
    ov = max(nz_v, default=0) + 1
    degrees = (bezier.shape[0] - 1, bezier.shape[1] - 1)
    for digits in _DIGIT_STEPS:
        values = [[_round_exact(int(n[j, i]), k, digits) for i in range(ov) for j in range(ou)] for n, k in exact]
        coeffs = [[_decimal_pair(d) for d in block] for block in values]
        if np.array_equal(_power_patch_to_bezier(coeffs, (ou, ov), degrees), bezier):
            break
    return (ou, ov), [_format_decimal(d) for block in values for d in block]


def _segment_power_tokens(bezier: np.ndarray) -> tuple[int, list[str]]:
    """Order and coefficient strings (one block per coordinate) of a Bezier curve segment."""
    exact = _exact_power_segment(bezier)
    nz = [j for j in range(bezier.shape[0]) if any(n[j] != 0 for n, _ in exact)]
    order = max(nz, default=0) + 1
    for digits in _DIGIT_STEPS:
        values = [[_round_exact(int(n[j]), k, digits) for j in range(order)] for n, k in exact]
        coeffs = [[_decimal_pair(d) for d in block] for block in values]
        if np.array_equal(_power_segment_to_bezier(coeffs, order, bezier.shape[0] - 1), bezier):
            break
    return order, [_format_decimal(d) for block in values for d in block]


# ----------------------------------------------------------------------------------------------
# records and statements
# ----------------------------------------------------------------------------------------------

@dataclass(frozen=True, slots=True)
class _Token:
    text: str
    line: int


@dataclass(frozen=True, slots=True)
class _Statement:
    name: str
    keyword: str
    tokens: tuple[_Token, ...]
    line: int


def _records(path: Path) -> list[str]:
    """Statement text (columns 1-72) of every record, checked for the 80-column layout."""
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise VdafsReadError(f"{path}: cannot read file ({exc.strerror or exc})") from None
    if not raw.strip():
        raise VdafsReadError(f"{path}: file is empty")
    nul = raw.find(b"\x00")
    if nul >= 0:
        raise VdafsReadError(f"{path}: binary data (NUL byte at offset {nul}); not a VDA-FS file")
    text = raw.decode("latin-1")
    out = []
    for number, record in enumerate(text.splitlines(), start=1):
        record = record.rstrip()
        if len(record) > _RECORD_COLS:
            raise VdafsReadError(f"{path}:{number}: record has {len(record)} columns; "
                                 f"VDA-FS records have at most {_RECORD_COLS}")
        if "\t" in record:
            raise VdafsReadError(f"{path}:{number}: TAB character; VDA-FS records hold blanks only")
        sequence = record[_TEXT_COLS:]
        if any(c in sequence for c in ",=/"):
            raise VdafsReadError(f"{path}:{number}: columns 73-80 must hold the sequence field; got "
                                 f"{sequence!r} (statement text runs past column 72)")
        out.append(record[:_TEXT_COLS])
    return out


def _strip_comment(text: str) -> str:
    at = text.find("$$")
    return (text if at < 0 else text[:at]).rstrip()


def _statements(path: Path, records: list[str]) -> list[_Statement]:
    """Split records into statements; the HEADER's free-text records are skipped."""
    statements: list[_Statement] = []
    # the open statement: name, keyword, line, whether it had a '/', and its text pieces with their lines
    pending: tuple[str, str, int, bool] | None = None
    parts: list[tuple[str, int]] = []
    tail = ""  # the open statement's text so far, stripped at the right (its last record's, when not blank)
    sets = 0

    def close() -> None:
        nonlocal pending, parts, sets
        if pending is None:
            return
        name, keyword, line, has_slash = pending
        tokens: list[_Token] = []
        if has_slash:
            carry, carry_line = "", line
            for piece, piece_line in parts:  # split piecewise: every token keeps its record's line
                pieces = (carry + piece).split(",")
                tokens.extend(_Token(t.strip(), piece_line) for t in pieces[:-1])
                carry, carry_line = pieces[-1], piece_line
            tokens.append(_Token(carry.strip(), carry_line))
        statements.append(_Statement(name, keyword, tuple(tokens), line))
        if keyword == "BEGINSET":
            sets += 1
        elif keyword == "ENDSET":
            sets -= 1
            if sets < 0:
                raise VdafsReadError(f"{path}:{line}: ENDSET {name}: no BEGINSET is open")
        pending, parts = None, []

    index = 0
    n_records = len(records)
    while index < n_records:
        number = index + 1
        text = _strip_comment(records[index])
        index += 1
        if not text.strip():
            continue
        if pending is not None:
            if tail.endswith(",") or (pending[3] and not tail):
                if "=" in text:
                    raise VdafsReadError(
                        f"{path}:{number}: {pending[1]} {pending[0]} (line {pending[2]}) ends with ',' but "
                        f"this record starts a new statement; statement truncated")
                parts.append((text, number))
                tail = text.rstrip()
                continue
        elif statements and statements[-1].keyword == "END":
            raise VdafsReadError(f"{path}:{number}: text after the END statement: {text.strip()[:40]!r}")
        match = _STATEMENT_RE.match(text)
        if match is None:
            if pending is not None:
                raise VdafsReadError(f"{path}:{number}: expected a new statement 'name = KEYWORD'; "
                                     f"{pending[1]} {pending[0]} (line {pending[2]}) does not end with ','; "
                                     f"got {text.strip()[:40]!r}")
            raise VdafsReadError(f"{path}:{number}: expected a statement 'name = KEYWORD / ...'; "
                                 f"got {text.strip()[:40]!r}")
        close()
        if statements and statements[-1].keyword == "END":
            raise VdafsReadError(f"{path}:{number}: text after the END statement: {text.strip()[:40]!r}")
        name, keyword, body = match.group(1), match.group(2).upper(), match.group(3)
        if len(name) > _NAME_MAX or not _NAME_RE.match(name):
            raise VdafsReadError(f"{path}:{number}: {keyword} {name!r}: a name has 1 to {_NAME_MAX} "
                                 f"letters, digits or '_'")
        if not statements and keyword != "HEADER":
            raise VdafsReadError(f"{path}:{number}: the first statement must be 'name = HEADER / n'; "
                                 f"got {keyword} {name}")
        if keyword == "HEADER":
            if statements:
                raise VdafsReadError(f"{path}:{number}: HEADER {name}: a second HEADER statement")
            count = _Token((body or "").strip(), number)
            n_header = _integer_token(path, count, f"HEADER {name}", "the number of header records", low=0)
            if index + n_header > n_records:
                raise VdafsReadError(f"{path}:{number}: HEADER {name}: announces {n_header} header records; "
                                     f"the file has {n_records - index} more")
            index += n_header
            statements.append(_Statement(name, keyword, (), number))
            continue
        pending = (name, keyword, number, body is not None)
        parts = [(body, number)] if body is not None else []
        tail = (body or "").rstrip()
    if pending is not None and tail.endswith(","):
        raise VdafsReadError(f"{path}:{pending[2]}: the file ends inside {pending[1]} {pending[0]} (its last "
                             f"record ends with ','); statement truncated")
    close()
    if not statements:
        raise VdafsReadError(f"{path}: no VDA-FS statements")
    if statements[-1].keyword != "END":
        last = statements[-1]
        raise VdafsReadError(f"{path}:{last.line}: the file ends after {last.keyword} {last.name} without an "
                             f"END statement; file truncated")
    if sets:
        raise VdafsReadError(f"{path}:{statements[-1].line}: {sets} BEGINSET without ENDSET")
    return statements


def _integer_token(path: Path, token: _Token, entity: str, what: str, *, low: int = 1) -> int:
    parsed = _parse_exact(token.text)
    if parsed is None:
        raise VdafsReadError(f"{path}:{token.line}: {entity}: {what} must be an integer; got {token.text!r}")
    m, e = parsed
    if e < 0:
        div = 10 ** (-e)
        if m % div:
            raise VdafsReadError(f"{path}:{token.line}: {entity}: {what} must be an integer; got {token.text!r}")
        value = m // div
    else:
        if e > 12:
            raise VdafsReadError(f"{path}:{token.line}: {entity}: {what} is too large: {token.text!r}")
        value = m * 10 ** e
    if value < low:
        raise VdafsReadError(f"{path}:{token.line}: {entity}: {what} must be >= {low}; got {token.text!r}")
    return value


# ----------------------------------------------------------------------------------------------
# entities
# ----------------------------------------------------------------------------------------------

class _Params:
    """Cursor over the parameters of one statement; errors name the file, line and entity."""

    def __init__(self, path: Path, statement: _Statement) -> None:
        self.path = path
        self.statement = statement
        self.entity = f"{statement.keyword} {statement.name}"
        self.tokens = statement.tokens
        self.pos = 0

    def error(self, message: str, token: _Token | None = None) -> VdafsReadError:
        line = token.line if token is not None else self.statement.line
        return VdafsReadError(f"{self.path}:{line}: {self.entity}: {message}")

    def _next(self, what: str) -> _Token:
        if self.pos >= len(self.tokens):
            raise self.error(f"statement ends before {what} (parameter {self.pos + 1}); "
                             f"statement truncated")
        token = self.tokens[self.pos]
        self.pos += 1
        return token

    def remaining(self) -> int:
        return len(self.tokens) - self.pos

    def need(self, count: int, what: str) -> None:
        if count > self.remaining():
            raise self.error(f"{what} need {count} more parameters; the statement has {self.remaining()}; "
                             f"statement truncated")

    def name(self, what: str, *, optional: bool = False) -> str | None:
        token = self._next(what)
        if not token.text and optional:
            return None
        if len(token.text) > _NAME_MAX or not _NAME_RE.match(token.text) or _parse_exact(token.text):
            raise self.error(f"{what} must be a name of 1 to {_NAME_MAX} letters or digits; got {token.text!r}",
                             token)
        return token.text

    def integer(self, what: str, *, low: int = 1) -> int:
        return _integer_token(self.path, self._next(what), self.entity, what, low=low)

    def real(self, what: str) -> float:
        token = self._next(what)
        if _parse_exact(token.text) is None:
            raise self.error(f"{what} must be a number; got {token.text!r}", token)
        value = float(token.text.replace("D", "E").replace("d", "e"))
        if not math.isfinite(value):
            raise self.error(f"{what} is out of the float64 range: {token.text!r}", token)
        return value

    def reals(self, count: int, what: str) -> np.ndarray:
        self.need(count, what)
        return np.array([self.real(f"{what} {i + 1}") for i in range(count)])

    def exacts(self, count: int, what: str) -> list[tuple[int, int]]:
        self.need(count, what)
        out = []
        for i in range(count):
            token = self._next(what)
            parsed = _parse_exact(token.text)
            if parsed is None:
                raise self.error(f"{what} {i + 1} must be a number; got {token.text!r}", token)
            m, e = parsed
            magnitude = len(str(abs(m))) + e  # decimal exponent of the leading digit, + 1
            if m and magnitude > 309:
                raise self.error(f"{what} {i + 1} is out of the float64 range: {token.text!r}", token)
            out.append(parsed if m and magnitude > -400 else (0, 0))  # below 1e-400: zero in float64
            # (bounds the size of the exact integers the conversion works with)
        return out

    def breaks(self, count: int, what: str) -> np.ndarray:
        first = self.tokens[self.pos] if self.pos < len(self.tokens) else None
        values = self.reals(count, what)
        if np.any(np.diff(values) <= 0):
            raise self.error(f"{what} must increase strictly; got {values.tolist()}", first)
        return values

    def done(self) -> None:
        if self.pos != len(self.tokens):
            token = self.tokens[self.pos]
            raise self.error(f"{len(self.tokens) - self.pos} parameters too many (from {token.text!r})", token)


@dataclass(frozen=True, slots=True)
class _Surf:
    name: str
    line: int
    patches: np.ndarray  # (nps, npt, du + 1, dv + 1, 3) Bezier control points, orders unified
    s_breaks: np.ndarray
    t_breaks: np.ndarray


@dataclass(frozen=True, slots=True)
class _Curve:
    name: str
    line: int
    segments: np.ndarray  # (n, p + 1, dim) Bezier control points, orders unified
    breaks: np.ndarray


@dataclass(frozen=True, slots=True)
class _Cons:
    name: str
    line: int
    surf: str
    curve: str | None
    s_range: tuple[float, float]
    plane: _Curve


@dataclass(frozen=True, slots=True)
class _Face:
    name: str
    line: int
    surf: str
    loops: tuple[tuple[tuple[str, float, float, int], ...], ...]  # (cons, w1, w2, line) per loop


def _parse_surf(p: _Params) -> _Surf:
    nps = p.integer("the number of patches in s (nps)")
    npt = p.integer("the number of patches in t (npt)")
    p.need(nps + npt + 2, "the global parameters s(1..nps+1), t(1..npt+1)")
    s_breaks = p.breaks(nps + 1, "s breakpoint")
    t_breaks = p.breaks(npt + 1, "t breakpoint")
    raw = []
    for j in range(npt):
        for i in range(nps):
            where = f"patch ({i + 1}, {j + 1})"
            ou = p.integer(f"{where}: the order in s")
            ov = p.integer(f"{where}: the order in t")
            size = ou * ov
            p.need(3 * size, f"{where}: its {ou} x {ov} coefficients of x, y, z")
            coeffs = [p.exacts(size, f"{where}: coefficient of {c}") for c in "xyz"]
            raw.append((i, j, ou, ov, coeffs))
    p.done()
    du = max(1, max(r[2] for r in raw) - 1)
    dv = max(1, max(r[3] for r in raw) - 1)
    patches = np.empty((nps, npt, du + 1, dv + 1, 3))
    for i, j, ou, ov, coeffs in raw:
        patches[i, j] = _power_patch_to_bezier(coeffs, (ou, ov), (du, dv))
    return _Surf(p.statement.name, p.statement.line, patches, s_breaks, t_breaks)


def _parse_segments(p: _Params, dim: int) -> _Curve:
    n = p.integer("the number of segments")
    breaks = p.breaks(n + 1, "segment breakpoint")
    raw = []
    axes = "xyz" if dim == 3 else "st"
    for k in range(n):
        order = p.integer(f"segment {k + 1}: the order")
        p.need(dim * order, f"segment {k + 1}: its {order} coefficients per coordinate")
        raw.append((order, [p.exacts(order, f"segment {k + 1}: coefficient of {c}") for c in axes]))
    degree = max(1, max(order for order, _ in raw) - 1)
    segments = np.array([_power_segment_to_bezier(coeffs, order, degree) for order, coeffs in raw])
    return _Curve(p.statement.name, p.statement.line, segments, breaks)


def _parse_curve(p: _Params) -> _Curve:
    curve = _parse_segments(p, 3)
    p.done()
    return curve


def _parse_cons(p: _Params) -> _Cons:
    surf = p.name("the SURF name")
    curve = p.name("the CURVE name", optional=True)
    s1 = p.real("the CURVE parameter s1")
    s2 = p.real("the CURVE parameter s2")
    plane = _parse_segments(p, 2)
    p.done()
    if curve is not None and s1 == s2:
        raise p.error(f"empty CURVE parameter range s1 = s2 = {s1!r}")
    return _Cons(p.statement.name, p.statement.line, surf, curve, (s1, s2), plane)


def _parse_face(p: _Params) -> _Face:
    surf = p.name("the SURF name")
    n_loops = p.integer("the number of trim loops")
    loops = []
    for k in range(n_loops):
        n_cons = p.integer(f"trim loop {k + 1}: the number of CONS")
        p.need(3 * n_cons, f"trim loop {k + 1}: its {n_cons} (CONS, w1, w2)")
        items = []
        for i in range(n_cons):
            line = p.tokens[p.pos].line
            name = p.name(f"trim loop {k + 1}: CONS name {i + 1}")
            w1 = p.real(f"trim loop {k + 1}: w1 of CONS {name}")
            w2 = p.real(f"trim loop {k + 1}: w2 of CONS {name}")
            items.append((name, w1, w2, line))
        loops.append(tuple(items))
    p.done()
    return _Face(p.statement.name, p.statement.line, surf, tuple(loops))


_PARSERS = {"SURF": _parse_surf, "CURVE": _parse_curve, "CONS": _parse_cons, "FACE": _parse_face}


# ----------------------------------------------------------------------------------------------
# reading
# ----------------------------------------------------------------------------------------------

def _warn(message: str) -> None:
    warnings.warn(message, TrimsurfWarning, stacklevel=3)


def _close_seams(patches: np.ndarray, where: str, tol_point: float) -> np.ndarray:
    """Make adjacent Bezier patches share their boundary rows (averaging); warn on gaps > tol_point."""
    out = patches.copy()
    worst = 0.0
    if out.shape[0] > 1:
        a, b = out[:-1, :, -1], out[1:, :, 0]
        worst = max(worst, float(np.max(np.linalg.norm(a - b, axis=-1))))
        mean = 0.5 * (a + b)
        out[:-1, :, -1] = mean
        out[1:, :, 0] = mean
    if out.shape[1] > 1:
        a, b = out[:, :-1, :, -1], out[:, 1:, :, 0]
        worst = max(worst, float(np.max(np.linalg.norm(a - b, axis=-1))))
        mean = 0.5 * (a + b)
        out[:, :-1, :, -1] = mean
        out[:, 1:, :, 0] = mean
    if worst > tol_point:
        _warn(f"{where}: adjacent patches do not meet: largest gap {worst:.3g} "
              f"(tolerance {tol_point:.3g}); the boundary control points were averaged")
    return out


def _surface(surf: _Surf, where: str, tol: Tolerance) -> NurbsSurface:
    patches = _close_seams(surf.patches, where, tol.point)
    pu, pv, ku, kv, cp, _ = bezier_grid_to_nurbs(patches, surf.s_breaks, surf.t_breaks)
    return NurbsSurface(pu, pv, ku, kv, cp)


def _curve(curve: _Curve, where: str, tol_point: float) -> NurbsCurve:
    """Bezier segments with C0 joints -> B-spline with interior knots of multiplicity p.

    Joints whose two segment ends differ are averaged (with a warning above `tol_point`).
    """
    segs = curve.segments.copy()
    if len(segs) > 1:
        ends, starts = segs[:-1, -1], segs[1:, 0]
        gaps = np.linalg.norm(ends - starts, axis=1)
        mean = 0.5 * (ends + starts)
        segs[:-1, -1] = mean
        segs[1:, 0] = mean
        worst = int(np.argmax(gaps))
        if gaps[worst] > tol_point:
            _warn(f"{where}: segments {worst + 1} and {worst + 2} do not meet: gap {gaps[worst]:.3g} "
                  f"(tolerance {tol_point:.3g}); the joint was averaged")
    p, knots, cp, _ = bezier_curve_to_nurbs(segs, curve.breaks)
    return NurbsCurve(p, knots, cp)


def _reparameterized(curve: NurbsCurve, w_range: tuple[float, float], s_range: tuple[float, float]) -> NurbsCurve:
    """The curve c(s) as a curve in w, with s = s1 + (w - w0) (s2 - s1) / (w1 - w0)."""
    (w0, w1), (s1, s2) = w_range, s_range
    if (s1, s2) == (w0, w1):
        return curve
    knots = w0 + (curve.knots - s1) * ((w1 - w0) / (s2 - s1))
    if s2 < s1:
        return NurbsCurve(curve.degree, knots[::-1], curve.control_points[::-1])
    return NurbsCurve(curve.degree, knots, curve.control_points)


def _default_tolerance(surfs: dict[str, _Surf]) -> Tolerance:
    if not surfs:
        return Tolerance()
    pts = np.concatenate([s.patches.reshape(-1, 3) for s in surfs.values()])
    return default_tolerance(float(np.linalg.norm(pts.max(axis=0) - pts.min(axis=0))))


def read(path: str | os.PathLike, *, tol: Tolerance | None = None) -> Shell:
    """Read the SURF, CURVE, CONS and FACE entities of a VDA-FS 2.0 file into a `Shell`.

    Parameters
    ----------
    path : str or os.PathLike
        A VDA-FS file (records of at most 80 columns).
    tol : Tolerance, optional
        Gaps above ``tol.point`` (between patches of a SURF or segments of a
        CURVE) and above ``tol.parameter`` times the larger side of a SURF's
        domain (between CONS in a trim loop, segments of a CONS) are reported.
        Default: `default_tolerance` of the control points' bounding-box diagonal.

    Returns
    -------
    Shell
        One `TrimmedFace` per FACE (named after it, loops in file order: the
        outer boundary first) and one untrimmed face per SURF that no FACE uses;
        no edges. The p-curves' edge curves are the CONS's CURVEs.

    Raises
    ------
    VdafsReadError
        Empty, truncated or malformed file (records, statements, numbers), or a
        FACE or CONS that refers to a missing SURF, CONS or CURVE.

    Warns
    -----
    TrimsurfWarning
        A trim loop with a gap, patches or segments that do not meet, a trim
        range outside its CONS, a CONS of zero length in a loop, an entity
        type outside the subset.

    Notes
    -----
    See the module docstring for the layout and the exactness of the
    monomial to Bezier conversion.

    Examples
    --------
    >>> import trimsurf.io._vdafs as vdafs, pathlib, tempfile
    >>> text = [
    ...     "DEMO     = HEADER / 1",
    ...     "a header record",
    ...     "S1       = SURF / 1, 1, 0., 1., 0., 1.,",
    ...     " 2, 2, 0., 1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1.",
    ...     "DEMO     = END"]
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "demo.vda"
    >>> _ = path.write_text("\\n".join(text) + "\\n")
    >>> face = vdafs.read(path).faces[0]
    >>> face.surface.evaluate([[0.5, 0.25]])   # x = s, y = t, z = s t
    array([[0.5  , 0.25 , 0.125]])
    """
    path = Path(path)
    statements = _statements(path, _records(path))
    entities: dict[str, dict] = {k: {} for k in _PARSERS}
    lines: dict[str, int] = {}
    order: list[tuple[str, str]] = []
    for st in statements:
        if st.keyword in ("HEADER", "END", "BEGINSET", "ENDSET"):
            continue
        if st.keyword in _SKIPPED:
            if st.keyword == "TLIST":
                _warn(f"{path}:{st.line}: TLIST {st.name}: transformed copies are not created")
            continue
        parser = _PARSERS.get(st.keyword)
        if parser is None:
            _warn(f"{path}:{st.line}: {st.keyword} {st.name}: entity type outside the VDA-FS subset "
                  f"(SURF, CURVE, CONS, FACE); skipped")
            continue
        if st.name in lines:
            raise VdafsReadError(f"{path}:{st.line}: {st.keyword} {st.name}: the name is already used "
                                 f"on line {lines[st.name]}")
        lines[st.name] = st.line
        entities[st.keyword][st.name] = parser(_Params(path, st))
        order.append((st.keyword, st.name))

    surfs, curves, conses, faces = (entities[k] for k in ("SURF", "CURVE", "CONS", "FACE"))
    tol = _default_tolerance(surfs) if tol is None else tol
    built_surfs: dict[str, NurbsSurface] = {}
    built_curves: dict[str, NurbsCurve] = {}

    def surface(name: str) -> NurbsSurface:
        if name not in built_surfs:
            s = surfs[name]
            built_surfs[name] = _surface(s, f"{path}:{s.line}: SURF {name}", tol)
        return built_surfs[name]

    def curve3d(name: str) -> NurbsCurve:
        if name not in built_curves:
            c = curves[name]
            built_curves[name] = _curve(c, f"{path}:{c.line}: CURVE {name}", tol.point)
        return built_curves[name]

    used = {f.surf for f in faces.values()}
    out: list[TrimmedFace] = []
    for keyword, name in order:
        if keyword == "SURF" and name not in used:
            out.append(TrimmedFace(surface(name), (), name=name))
        elif keyword == "FACE":
            out.append(_face(path, faces[name], surfs, conses, curves, surface, curve3d, tol))
    if not out:
        raise VdafsReadError(f"{path}: no SURF or FACE entity; nothing to read")
    return Shell(tuple(out), name=str(path))


def _face(path: Path, face: _Face, surfs, conses, curves, surface, curve3d, tol: Tolerance) -> TrimmedFace:
    where = f"{path}:{face.line}: FACE {face.name}"
    if face.surf not in surfs:
        raise VdafsReadError(f"{where}: refers to SURF {face.surf}, which is not in the file")
    surf = surface(face.surf)
    (u0, u1), (v0, v1) = surf.domain
    tol_uv = tol.parameter * max(u1 - u0, v1 - v0)
    loops = []
    for k, items in enumerate(face.loops):
        segments = []
        names = []
        for cons_name, w1, w2, line in items:
            here = f"{path}:{line}: FACE {face.name}"
            cons = conses.get(cons_name)
            if cons is None:
                raise VdafsReadError(f"{here}: trim loop {k + 1} refers to CONS {cons_name}, "
                                     f"which is not in the file")
            if cons.surf != face.surf:
                raise VdafsReadError(f"{here}: CONS {cons_name} lies on SURF {cons.surf}, not on the face's "
                                     f"SURF {face.surf}")
            if cons.curve is not None and cons.curve not in curves:
                raise VdafsReadError(f"{path}:{cons.line}: CONS {cons_name} (used by FACE {face.name}) refers "
                                     f"to CURVE {cons.curve}, which is not in the file")
            plane = _curve(cons.plane, f"{path}:{cons.line}: CONS {cons_name}", tol_uv)
            c0, c1 = plane.domain
            if w1 == w2:
                _warn(f"{here}: trim loop {k + 1}: CONS {cons_name} is used over the empty range "
                      f"[{w1!r}, {w2!r}]; left out")
                continue
            if min(w1, w2) < c0 - tol.parameter * (c1 - c0) or max(w1, w2) > c1 + tol.parameter * (c1 - c0):
                _warn(f"{here}: trim loop {k + 1}: range [{w1!r}, {w2!r}] of CONS {cons_name} exceeds its "
                      f"domain [{c0!r}, {c1!r}]; evaluated clamped")
            edge = None
            if cons.curve is not None:
                space = curve3d(cons.curve)
                (k0, k1), (lo, hi) = space.domain, sorted(cons.s_range)
                if lo < k0 - tol.parameter * (k1 - k0) or hi > k1 + tol.parameter * (k1 - k0):
                    _warn(f"{path}:{cons.line}: CONS {cons_name}: its range [{cons.s_range[0]!r}, "
                          f"{cons.s_range[1]!r}] on CURVE {cons.curve} exceeds the curve's domain "
                          f"[{k0!r}, {k1!r}]")
                edge = _reparameterized(space, (c0, c1), cons.s_range)
            segments.append(PCurve(plane, w1, w2, edge_curve=edge))
            names.append(cons_name)
        if not segments:
            raise VdafsReadError(f"{where}: trim loop {k + 1} has no CONS of non-zero length")
        loop = Loop(tuple(segments))
        gaps = loop.gaps()
        worst = int(np.argmax(gaps))
        if gaps[worst] > tol_uv:
            _warn(f"{where}: trim loop {k + 1} is not closed: gap {gaps[worst]:.3g} in (u, v) after CONS "
                  f"{names[worst]} (tolerance {tol_uv:.3g})")
        loops.append(loop)
    return TrimmedFace(surf, _oriented_loops(loops, where, tol_uv), name=face.name)


def _reversed_loop(loop: Loop) -> Loop:
    """The loop run the other way: segments in reverse order, each used from t1 to t0."""
    return Loop(tuple(PCurve(s.curve, s.t1, s.t0, s.edge_curve, s.edge_id) for s in reversed(loop.segments)))


def _distances_to_polygon(points: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """Distance of each point (n, 2) to the closed polygon (k, 2), shape (n,)."""
    a, b = polygon, np.roll(polygon, -1, axis=0)
    d = b - a
    dd = np.einsum("ij,ij->i", d, d)
    out = np.empty(len(points))
    step = max(1, (1 << 20) // max(1, len(a)))  # bounds memory: points x edges pairs at once
    for i in range(0, len(points), step):
        p = points[i:i + step, None, :]
        with np.errstate(divide="ignore", invalid="ignore"):
            s = np.einsum("nkj,kj->nk", p - a[None], d) / dd
        s = np.clip(np.nan_to_num(s, nan=0.0), 0.0, 1.0)
        out[i:i + step] = np.linalg.norm(p - (a[None] + s[..., None] * d[None]), axis=2).min(axis=1)
    return out


def _oriented_loops(loops: list[Loop], where: str, tol_uv: float) -> tuple[Loop, ...]:
    """Loops in the model's orientation: the first (outer) counter-clockwise in (u, v), the others clockwise.

    A loop of the wrong sense is reversed (`_reversed_loop`) silently: VDA-FS
    does not fix the sense. Roles come from the file order (the first loop is
    the outer boundary); a warning names the FACE when the file's loops do
    not fit these roles: a loop of (nearly) zero area, a hole not inside the
    outer loop, or a hole inside another hole. Points within `tol_uv` of the
    other loop count as inside (loops may touch).
    """
    polys = [loop.polyline(_ORIENT_SAMPLES) for loop in loops]
    out = []
    for k, (loop, poly) in enumerate(zip(loops, polys)):
        area = polygon_signed_area(poly)
        perimeter = float(np.sum(np.linalg.norm(np.roll(poly, -1, axis=0) - poly, axis=1)))
        if abs(area) <= tol_uv * perimeter:
            _warn(f"{where}: trim loop {k + 1} encloses (nearly) no area ({area:.3g}); its sense is kept as read")
        elif (area > 0) != (k == 0):
            loop = _reversed_loop(loop)
        out.append(loop)
    if len(polys) > 1:
        outer = polys[0]
        for k in range(1, len(polys)):
            pts = polys[k]
            outside = ~points_in_polygons(pts, [outer])
            if outside.any() and _distances_to_polygon(pts[outside], outer).max() > tol_uv:
                _warn(f"{where}: trim loop {k + 1} (a hole) is not inside the outer trim loop 1 "
                      "(loops in the wrong order, or crossing)")
                continue
            for j in range(1, len(polys)):
                if j != k and _inside_beyond(polys[j][:1], polys[k], tol_uv):
                    _warn(f"{where}: trim loop {j + 1} (a hole) lies inside the hole trim loop {k + 1}")
    return tuple(out)


def _inside_beyond(points: np.ndarray, polygon: np.ndarray, tol: float) -> bool:
    """Whether some point lies inside `polygon` by more than `tol`."""
    inside = points_in_polygons(points, [polygon])
    return bool(inside.any() and _distances_to_polygon(points[inside], polygon).max() > tol)


# ----------------------------------------------------------------------------------------------
# writing
# ----------------------------------------------------------------------------------------------

_HEADER_LINES = (
    "*" * 71,
    "VDAFS VERSION     :  2.0",
    "-" * 29 + " SENDER DATA " + "-" * 29,
    "SENDER COMPANY    :  UNKNOWN",
    "CONTACT PERSON    :  UNKNOWN",
    "TELEPHONE NO.     :  UNKNOWN",
    "ADDRESS           :  UNKNOWN",
    "SENDING SYSTEM    :  TRIMSURF",
    "SENDING DATE      :  UNKNOWN",
    "FILE NAME         :  {file}",
    "-" * 30 + " PART DATA " + "-" * 30,
    "PROJECT NAME      :  UNKNOWN",
    "OBJECT CODE       :  NONE",
    "VARIANT           :  NONE",
    "CONFIDENTIALITY   :  UNCLASSIFIED",
    "DATE EFFECTIVE    :  UNKNOWN",
    "-" * 28 + " RECEIVER DATA " + "-" * 28,
    "COMPANY NAME      :  UNKNOWN",
    "RECEIVER NAME     :  UNKNOWN",
    "*" * 71,
)


class _Records:
    """Statement text wrapped into 80-column records: text in columns 1-72, record number in 73-80."""

    def __init__(self) -> None:
        self.lines: list[str] = []

    def record(self, text: str) -> None:
        if len(text) > _TEXT_COLS:
            raise InputError(f"internal: VDA-FS record text longer than {_TEXT_COLS} columns: {text[:40]!r}")
        self.lines.append(f"{text:<{_TEXT_COLS}}{len(self.lines) + 1:08d}")

    def statement(self, name: str, keyword: str, tokens: list[str] | None = None) -> None:
        head = f"{name:<{_NAME_MAX}} = {keyword}"
        if tokens is None:
            self.record(head)
            return
        current = head + " /"
        fresh = False  # whether `current` holds no parameter yet (a new continuation record)
        last = len(tokens) - 1
        for i, token in enumerate(tokens):
            piece = token + ("," if i < last else "")
            candidate = current + ("" if fresh else " ") + piece
            if len(candidate) > _TEXT_COLS:
                self.record(current)
                current, fresh = "  ", True
                candidate = current + piece
            current, fresh = candidate, False
        self.record(current)

    def text(self) -> str:
        return "\n".join(self.lines) + "\n"


class _Names:
    """Unique VDA-FS names: preferred ones kept when valid, others generated as PREFIX + number."""

    def __init__(self) -> None:
        self.used: set[str] = set()
        self.counters: dict[str, int] = {}

    @staticmethod
    def is_valid(name: str) -> bool:
        return 0 < len(name) <= _NAME_MAX and bool(_NAME_RE.match(name)) and _parse_exact(name) is None

    def reserve(self, name: str) -> bool:
        if self.is_valid(name) and name not in self.used:
            self.used.add(name)
            return True
        return False

    def new(self, prefix: str) -> str:
        while True:
            self.counters[prefix] = self.counters.get(prefix, 0) + 1
            name = f"{prefix}{self.counters[prefix]}"
            if name not in self.used:
                self.used.add(name)
                return name


def _surface_tokens(patches: np.ndarray, u_breaks: np.ndarray, v_breaks: np.ndarray) -> list[str]:
    nps, npt = patches.shape[:2]
    tokens = [str(nps), str(npt)] + [_format_float(x) for x in u_breaks] + [_format_float(x) for x in v_breaks]
    for j in range(npt):
        for i in range(nps):
            (ou, ov), coeffs = _patch_power_tokens(patches[i, j])
            tokens += [str(ou), str(ov)] + coeffs
    return tokens


def _segments_tokens(segments: np.ndarray, breaks: np.ndarray) -> list[str]:
    tokens = [str(len(segments))] + [_format_float(x) for x in breaks]
    for seg in segments:
        order, coeffs = _segment_power_tokens(seg)
        tokens += [str(order)] + coeffs
    return tokens


def _extract_curve(curve: NurbsCurve) -> tuple[np.ndarray, np.ndarray]:
    """Bezier segments (k, p + 1, dim) and breaks (k + 1,) of a polynomial B-spline curve."""
    breaks, segments, _ = bezier_extract(curve.degree, curve.knots, curve.control_points, None)
    return segments, breaks


def _extract_surface(surface: NurbsSurface) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Bezier patches (m, n, du + 1, dv + 1, 3) and breaks of a polynomial B-spline surface."""
    u_breaks, v_breaks, patches, _ = bezier_extract_surface(
        surface.degree_u, surface.degree_v, surface.knots_u, surface.knots_v, surface.control_points)
    return patches, u_breaks, v_breaks


def write(shell: Shell, path: str | os.PathLike) -> None:
    """Write the faces of a `Shell` as VDA-FS 2.0 SURF, CURVE, CONS and FACE entities.

    Each face's surface is written as a SURF of its Bezier patches (Bezier
    extraction at the knots), each p-curve as a CONS of its Bezier segments
    with its edge curve, if any, as the CONS's CURVE, and each trimmed face as
    a FACE; an untrimmed face is a SURF alone (named after the face). Face
    names of at most 8 letters or digits are kept; other names are generated.

    Parameters
    ----------
    shell : Shell
    path : str or os.PathLike
        Output file; written to a temporary file and renamed, so a failed
        write leaves no partial file.

    Raises
    ------
    InputError
        `shell` is not a Shell or has no face.
    GeometryError
        A rational surface or p-curve (VDA-FS holds polynomials only: it could
        not be written exactly); the message names the face.

    Warns
    -----
    TrimsurfWarning
        A rational edge curve is left out (the CONS is written without CURVE).

    Notes
    -----
    Monomial coefficients are written with as many significant digits as
    this reader needs to get back the same floats (see the module docstring).
    """
    if not isinstance(shell, Shell):
        raise InputError(f"{path}: VDA-FS write expects a Shell; got {type(shell).__name__}")
    if not shell.faces:
        raise InputError(f"{path}: the shell has no face to write")
    out = _Records()
    out.statement("TRIMSURF", "HEADER", [str(len(_HEADER_LINES))])
    for line in _HEADER_LINES:
        out.record(line.format(file=Path(path).name[:50]))
    names = _Names()
    face_names = [face.name if names.reserve(face.name) else None for face in shell.faces]
    for index, face in enumerate(shell.faces):
        label = f"face {index}" + (f" ({face.name!r})" if face.name else "")
        surface = face.surface
        if surface.is_rational:
            raise GeometryError(f"{path}: {label}: rational surface; a VDA-FS SURF holds polynomial patches "
                                f"only, so it cannot be written exactly")
        for k, loop in enumerate(face.loops):
            for i, seg in enumerate(loop.segments):
                if seg.curve.is_rational:
                    raise GeometryError(f"{path}: {label}: trim loop {k}, segment {i}: rational p-curve; a "
                                        f"VDA-FS CONS holds polynomial segments only")
        if not face.loops:
            surf_name = face_names[index] or names.new("S")
            out.statement(surf_name, "SURF", _surface_tokens(*_extract_surface(surface)))
            continue
        surf_name = names.new("S")
        face_name = face_names[index] or names.new("F")
        out.statement(surf_name, "SURF", _surface_tokens(*_extract_surface(surface)))
        loops_tokens = [str(len(face.loops))]
        for k, loop in enumerate(face.loops):
            loops_tokens.append(str(len(loop.segments)))
            for i, seg in enumerate(loop.segments):
                curve_name = ""
                edge = seg.edge_curve
                if edge is not None and edge.is_rational:
                    _warn(f"{path}: {label}: trim loop {k}, segment {i}: rational edge curve left out "
                          f"(VDA-FS CURVE segments are polynomial)")
                    edge = None
                if edge is not None:
                    curve_name = names.new("K")
                    out.statement(curve_name, "CURVE", _segments_tokens(*_extract_curve(edge)))
                segments, breaks = _extract_curve(seg.curve)
                cons_name = names.new("C")
                out.statement(cons_name, "CONS", [surf_name, curve_name, _format_float(breaks[0]),
                                                  _format_float(breaks[-1])] + _segments_tokens(segments, breaks))
                loops_tokens += [cons_name, _format_float(seg.t0), _format_float(seg.t1)]
        out.statement(face_name, "FACE", [surf_name] + loops_tokens)
    out.statement("TRIMSURF", "END")
    text = out.text()
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="ascii", newline="\n")

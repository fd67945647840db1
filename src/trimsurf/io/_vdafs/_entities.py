"""The VDA-FS entities of the subset: SURF, CURVE, CONS, FACE, parsed from statements."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...errors import VdafsReadError
from ._exact import _parse_exact, _power_patch_to_bezier, _power_segment_to_bezier
from ._records import _NAME_MAX, _NAME_RE, _integer_token, _Statement, _Token


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

    def breaks(self, count: int, what: str, *, strict: bool = True) -> np.ndarray:
        """`count` breakpoints; with ``strict`` (default) they must increase strictly."""
        first = self.tokens[self.pos] if self.pos < len(self.tokens) else None
        values = self.reals(count, what)
        if strict and np.any(np.diff(values) <= 0):
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
    # checked by the reader (a SURF whose breakpoints do not increase is read and its faces rejected
    # by name in `trimsurf.tessellate.repair`, instead of the whole file failing)
    s_breaks = p.breaks(nps + 1, "s breakpoint", strict=False)
    t_breaks = p.breaks(npt + 1, "t breakpoint", strict=False)
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

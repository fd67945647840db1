"""Writing a `Shell` as a VDA-FS file."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ...errors import GeometryError, InputError
from ...geom.knots import (
    bezier_extract,
    bezier_extract_surface,
)
from ...model import NurbsCurve, NurbsSurface, Shell
from .._atomic import atomic_path
from ._exact import (
    _format_float,
    _parse_exact,
    _patch_power_tokens,
    _segment_power_tokens,
)
from ._reader import _warn
from ._records import _NAME_MAX, _NAME_RE, _TEXT_COLS

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

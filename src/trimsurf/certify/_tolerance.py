"""The model's point tolerance as its file states it (STEP: UNCERTAINTY_MEASURE_WITH_UNIT)."""

from __future__ import annotations

import re
from pathlib import Path

__all__ = ["file_point_tolerance"]

_UNCERTAINTY = re.compile(r"UNCERTAINTY_MEASURE_WITH_UNIT\s*\(\s*LENGTH_MEASURE\s*\(\s*([-+0-9.Ee]+)\s*\)\s*,\s*#(\d+)")
_PREFIX = {"MILLI": 1.0, "CENTI": 10.0, "DECI": 100.0, "KILO": 1e6, "MICRO": 1e-3, "NANO": 1e-6}
_NAMED = {"INCH": 25.4, "FOOT": 304.8, "MILLIMETRE": 1.0, "METRE": 1000.0}


def file_point_tolerance(path) -> float | None:
    """The length uncertainty a STEP file states, in millimetres (the unit the readers return), or None.

    Reads ``UNCERTAINTY_MEASURE_WITH_UNIT(LENGTH_MEASURE(x), #u, ...)`` and converts x from the unit #u
    (SI metre with or without a prefix, or a conversion-based inch / foot). None for other formats, no
    statement, or a unit it does not know.

    Examples
    --------
    >>> import tempfile
    >>> text = ("#5=( LENGTH_UNIT() NAMED_UNIT(*) CONVERSION_BASED_UNIT('INCH',#4) );\\n"
    ...         "#6=UNCERTAINTY_MEASURE_WITH_UNIT(LENGTH_MEASURE(1.E-06),#5,'distance_accuracy_value','');\\n")
    >>> with tempfile.TemporaryDirectory() as d:
    ...     p = Path(d) / "a.step"
    ...     _ = p.write_text(text)
    ...     round(file_point_tolerance(p), 12)
    2.54e-05
    """
    p = Path(path)
    if p.suffix.lower() not in (".step", ".stp"):
        return None
    try:
        text = p.read_text(errors="replace")
    except OSError:
        return None
    m = _UNCERTAINTY.search(text)
    if m is None:
        return None
    value = float(m.group(1))
    unit = re.search(r"#" + m.group(2) + r"\s*=\s*([^;]*);", text, re.S)
    if unit is None or not (value > 0):
        return None
    u = unit.group(1).upper()
    conv = re.search(r"CONVERSION_BASED_UNIT\s*\(\s*'([A-Z]+)'", u)
    if conv:
        factor = _NAMED.get(conv.group(1))
    else:
        si = re.search(r"SI_UNIT\s*\(\s*(\$|\.[A-Z]+\.)\s*,\s*\.METRE\.", u)
        if si is None:
            return None
        factor = 1000.0 if si.group(1) == "$" else _PREFIX.get(si.group(1).strip("."))
    return None if factor is None else value * factor

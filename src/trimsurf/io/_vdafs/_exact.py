"""Exact monomial <-> Bernstein conversion and shortest exact decimal numbers (VDA-FS coefficients)."""

from __future__ import annotations

import math
import re
from decimal import ROUND_HALF_EVEN, Context, Decimal
from functools import lru_cache

import numpy as np

# significant digits the writer tries, in turn, until the reader gets back the same floats
_DIGIT_STEPS = (17, 20, 24, 30, 40, 50, 60)
_NUMBER_RE = re.compile(r"([+-]?)(\d*)(?:\.(\d*))?(?:[EeDd]([+-]?\d+))?\Z")


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

"""VDA-FS records (80 columns, text in 1-72) and ``name = KEYWORD / ...`` statements."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from ...errors import VdafsReadError
from ._exact import _parse_exact

_RECORD_COLS = 80
_TEXT_COLS = 72
_NAME_MAX = 8

_NAME_RE = re.compile(r"[A-Za-z0-9_]+\Z")
_STATEMENT_RE = re.compile(r"\s*([^\s=]+)\s*=\s*([A-Za-z$]+)\s*(?:/(.*))?\Z")


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

"""A cache on disk of the shells the reader server's children make (STEP, IGES, BREP), for repeated reads.

Reading a CAD file costs the reader server's start (an interpreter importing Open CASCADE, ~0.5 s CPU)
and Open CASCADE's own work in the child (parse, transfer, ``BRepBuilderAPI_NurbsConvert``: 0.1-0.8 s on
the shared files), most of it in the B-spline conversion, whose projections of p-curves *are* its result
(`trimsurf.io._occ._read.nurbs_shape`): no cheaper route gives the same shells. A file read again -- the
usual case: tessellating one part at several tolerances, viewing it, certifying it -- is the same work
for the same result. So the child's answer (the pickled ``("ok", shell, warnings)`` it wrote, byte for
byte) is kept under a key of

* the file's bytes (BLAKE2b), the format and the path as the caller gave it (the shell's name and the
  warnings' messages name it);
* the reader's code: size and modification time of every ``.py`` file of the trimsurf package (as
  numba's cache keys its compiled functions: any edit invalidates), the Python version, and the files
  of Open CASCADE's bindings (OCP) and numpy.

A read with a key found loads that answer (the same bytes unpickled: the same shell bit for bit, the same
warnings given again) without the server. Only successful reads are kept (an error is read again, so a
crash or hang stays contained in a child); an entry whose file changed during the read is not kept.

Where: ``TRIMSURF_READ_CACHE`` = a folder, ``0`` (off), or unset: ``$XDG_CACHE_HOME/trimsurf/read`` (else
``~/.cache/trimsurf/read``). The folder keeps at most `MAX_BYTES`; the entries used least recently go
first. This module imports nothing heavy (the ``trimsurf`` command consults it before its own imports,
`trimsurf.io._server.start_early`).
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import sys
from pathlib import Path

__all__ = ["cache_dir", "key", "load", "store", "FORMATS"]

#: the environment variable: a folder, or 0/off/no/false to read without the cache
ENV = "TRIMSURF_READ_CACHE"
#: the folder's size limit (bytes); the least recently used entries are removed beyond it
MAX_BYTES = 512 * 1024 * 1024
#: the format read for each suffix the server reads
FORMATS = {".step": "STEP", ".stp": "STEP", ".iges": "IGES", ".igs": "IGES", ".brep": "BREP"}
_SUFFIX = ".pickle"

_code_key: str | None = None
#: key of a file already hashed in this process: (path, fmt, cwd, stat) -> key
_seen: dict[tuple, str] = {}
#: the file each key was made from: key -> (path, stat)
_made: dict[str, tuple] = {}


def cache_dir() -> Path | None:
    """The cache folder, or None when the cache is off (``TRIMSURF_READ_CACHE=0``)."""
    value = os.environ.get(ENV, "").strip()
    if value.lower() in ("0", "off", "no", "false"):
        return None
    if value and value.lower() not in ("1", "on", "yes", "true"):
        return Path(value)
    base = os.environ.get("XDG_CACHE_HOME", "").strip() or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "trimsurf" / "read"


def _stat_key(path: str) -> tuple:
    st = os.stat(path)
    return (st.st_size, st.st_mtime_ns, st.st_ino, st.st_dev)


def code_key() -> str:
    """The reader's code: every trimsurf ``.py`` file's size and mtime, Python, OCP's and numpy's files."""
    global _code_key
    if _code_key is None:
        h = hashlib.blake2b(digest_size=16)
        h.update(sys.version.encode())
        h.update(sources_key(Path(__file__).resolve().parents[1]).encode())
        import importlib.util

        for package in ("OCP", "numpy"):
            with contextlib.suppress(Exception):
                spec = importlib.util.find_spec(package)
                where = Path(spec.origin).parent
                for p in sorted(where.glob("*.so")) + [where / "__init__.py", where / "version.py"]:
                    if p.is_file():
                        st = p.stat()
                        h.update(f"{p}\0{st.st_size}\0{st.st_mtime_ns}\n".encode())
        _code_key = h.hexdigest()
    return _code_key


def sources_key(root: Path) -> str:
    """A digest of the relative path, size and modification time of every ``.py`` file under `root`."""
    h = hashlib.blake2b(digest_size=16)
    for folder, dirs, files in os.walk(root):
        dirs[:] = sorted(d for d in dirs if d != "__pycache__")
        for name in sorted(files):
            if name.endswith(".py"):
                p = os.path.join(folder, name)
                st = os.stat(p)
                h.update(f"{os.path.relpath(p, root)}\0{st.st_size}\0{st.st_mtime_ns}\n".encode())
    return h.hexdigest()


def key(path: str | os.PathLike, fmt: str) -> str | None:
    """The cache key of reading `path` as `fmt` now; None when the cache is off or the file cannot be read."""
    if cache_dir() is None:
        return None
    text = os.fspath(path)
    try:
        where = (text, fmt, os.getcwd(), _stat_key(text))
        if where in _seen:
            _made[_seen[where]] = (text, where[3])
            return _seen[where]
        h = hashlib.blake2b(digest_size=20)
        with open(text, "rb") as fh:
            while chunk := fh.read(1 << 20):
                h.update(chunk)
        h.update(f"\0{fmt}\0{text}\0{code_key()}".encode("utf-8", "surrogateescape"))
        if _stat_key(text) != where[3]:  # changed while hashed
            return None
    except OSError:
        return None
    k = _seen[where] = h.hexdigest()
    _made[k] = (text, where[3])
    return k


def _entry(k: str) -> Path | None:
    folder = cache_dir()
    return None if folder is None else folder / (k + _SUFFIX)


def has(k: str | None) -> bool:
    """Whether an entry for key `k` exists (not whether it loads)."""
    entry = None if k is None else _entry(k)
    return entry is not None and entry.is_file()


def load(k: str | None) -> bytes | None:
    """The stored answer for key `k` (marked as used now), or None."""
    entry = None if k is None else _entry(k)
    if entry is None:
        return None
    try:
        data = entry.read_bytes()
        os.utime(entry)
    except OSError:
        return None
    return data


def drop(k: str | None) -> None:
    """Remove the entry for key `k` (it did not load)."""
    entry = None if k is None else _entry(k)
    if entry is not None:
        with contextlib.suppress(OSError):
            entry.unlink()


def store(k: str | None, answer: str | os.PathLike, path: str | os.PathLike) -> None:
    """Keep the answer file `answer` under key `k`, unless `path` changed since `k` was made; never raises."""
    entry = None if k is None else _entry(k)
    if entry is None:
        return
    try:
        text = os.fspath(path)
        if _made.get(k) != (text, _stat_key(text)):
            return  # the file changed during the read
        import tempfile

        entry.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
        data = Path(answer).read_bytes()
        fd, tmp = tempfile.mkstemp(dir=entry.parent, prefix=".tmp-", suffix=_SUFFIX)
        try:
            with os.fdopen(fd, "wb") as fh:
                fh.write(data)
            os.replace(tmp, entry)
        except BaseException:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
            raise
        _trim(entry.parent)
    except Exception:  # noqa: BLE001 - a cache: a failed store only means the next read is not faster
        pass


def _trim(folder: Path) -> None:
    """Remove the least recently used entries while the folder holds more than `MAX_BYTES`."""
    entries = []
    for p in folder.glob("*" + _SUFFIX):
        with contextlib.suppress(OSError):
            st = p.stat()
            entries.append((st.st_mtime_ns, st.st_size, p))
    total = sum(e[1] for e in entries)
    for _, size, p in sorted(entries):
        if total <= MAX_BYTES:
            break
        with contextlib.suppress(OSError):
            p.unlink()
            total -= size

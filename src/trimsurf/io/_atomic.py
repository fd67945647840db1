"""Write outputs to a temporary file and rename, so a failed run leaves no half-written file.

The file that appears under the target name has the mode a plain ``open(path,
"w")`` would give it: an existing target keeps its mode, a new one gets
``0o666 & ~umask`` (`tempfile.mkstemp` alone would make every output 0600).
Errors name the target, never the temporary file.
"""

from __future__ import annotations

import contextlib
import os
import stat
import tempfile
from pathlib import Path

__all__ = ["atomic_path", "new_file_mode"]


def _umask() -> int:
    """The process umask, read without changing it where Linux reports it (else set and restored)."""
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def new_file_mode(target: str | os.PathLike) -> int:
    """The permission bits a normal write of `target` leaves: its current ones, else 0o666 & ~umask."""
    try:
        return stat.S_IMODE(os.stat(target).st_mode)
    except OSError:
        return 0o666 & ~_umask()


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike):
    """Yield a temporary path beside `path`; rename it onto `path` when the block succeeds.

    The temporary file keeps the target's suffix, so writers that choose the
    format from the suffix (Open CASCADE, trimesh) behave as for the target.
    It is removed whenever the block does not succeed (an exception, Ctrl-C,
    SIGTERM through the CLI).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     target = pathlib.Path(folder) / "a.txt"
    ...     with atomic_path(target) as tmp:
    ...         _ = tmp.write_text("x")
    ...     names = sorted(p.name for p in pathlib.Path(folder).iterdir())
    ...     names, target.stat().st_mode & 0o777 == 0o666 & ~_umask()
    (['a.txt'], True)
    """
    target = Path(path)
    if target.is_dir():
        raise IsADirectoryError(21, "is a folder, not a file", str(target))
    target.parent.mkdir(parents=True, exist_ok=True)
    mode = new_file_mode(target)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{target.stem}.", suffix=target.suffix, dir=target.parent)
    except OSError as exc:
        raise type(exc)(exc.errno, exc.strerror, str(target)) from None
    try:
        try:
            os.fchmod(fd, mode)
        finally:
            os.close(fd)
        try:
            yield Path(tmp)
        except OSError as exc:  # e.g. a full disk while writing: the user's path, not the temporary one
            if exc.filename is not None and os.fspath(exc.filename) == tmp and exc.errno is not None:
                raise type(exc)(exc.errno, exc.strerror, str(target)) from None
            raise
        try:
            os.chmod(tmp, mode)  # a writer may have replaced the file
            os.replace(tmp, target)
        except OSError as exc:
            raise type(exc)(exc.errno, exc.strerror, str(target)) from None
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)

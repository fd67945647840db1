"""Readers and writers: STEP/IGES/BREP (Open CASCADE), the VDAFS subset (by hand), meshes (trimesh, meshio).

`read` picks the reader from the file suffix and returns a `Shell` for CAD
files and a `TriMesh` for mesh files. Writers write to a temporary file and
rename it, so a failed write never leaves a partial file. `from_occ` and
`to_occ` convert in-memory Open CASCADE shapes (plain OCP, CadQuery,
build123d) the way the STEP reader and writer do.
"""

from __future__ import annotations

import contextlib
import os
import warnings
from collections.abc import Iterator
from importlib import import_module
from pathlib import Path
from typing import TYPE_CHECKING

from ..errors import FaceSkippedWarning, FileFormatError
from . import _server

if TYPE_CHECKING:  # not imported at run time: `trimsurf.io._server` must stay cheap to import (trimsurf.cli)
    from ..model import Shell, TriMesh

__all__ = ["read", "read_shell", "read_mesh", "write_shell", "write_mesh", "CAD_SUFFIXES", "MESH_SUFFIXES",
           "occ_mesh_faces", "skipped_faces", "from_occ", "to_occ"]

# suffix -> private module holding read(path) and write(obj, path)
_CAD_MODULES = {".step": "_step", ".stp": "_step", ".iges": "_iges", ".igs": "_iges", ".brep": "_brep",
                ".vda": "_vdafs", ".vdafs": "_vdafs", ".vdas": "_vdafs"}
_MESH_SUFFIXES = (".obj", ".ply", ".stl", ".off", ".gltf", ".glb",  # trimesh (and by hand)
                  ".vtk", ".vtu", ".msh", ".inp", ".bdf", ".nas")     # meshio
CAD_SUFFIXES = tuple(_CAD_MODULES)
MESH_SUFFIXES = _MESH_SUFFIXES


def _suffix(path: str | os.PathLike) -> str:
    return Path(path).suffix.lower()


def _cad_module(path):
    suffix = _suffix(path)
    if suffix not in _CAD_MODULES:
        raise FileFormatError(f"{path}: unknown CAD file suffix {suffix!r}; expected one of {', '.join(CAD_SUFFIXES)}")
    return import_module(f".{_CAD_MODULES[suffix]}", __name__)


def check_readable(path, error: type[FileFormatError] = FileFormatError) -> Path:
    """`path` as a Path; raises `error` (a FileFormatError kind) unless it is an existing, non-empty file."""
    p = Path(path)
    if not p.is_file():
        raise error(f"{path}: no such file")
    if p.stat().st_size == 0:
        raise error(f"{path}: file is empty")
    return p


def read_shell(path: str | os.PathLike) -> Shell:
    """Read a STEP, IGES, BREP (Open CASCADE) or VDAFS file into a `Shell`."""
    if _suffix(path) in _CAD_MODULES:
        check_readable(path)
        # the reader server (a fresh interpreter importing Open CASCADE) starts before this process imports the
        # readers and the model (numba), so the two overlap on a first read
        _server.start_for(path)
    module = _cad_module(path)
    check_readable(path)
    return module.read(path)


@contextlib.contextmanager
def skipped_faces() -> Iterator[list[str]]:
    """Collect the `FaceSkippedWarning` messages of the reads in the block (they are still shown).

    >>> with skipped_faces() as skipped:
    ...     pass
    >>> skipped
    []
    """
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        found: list[str] = []
        try:
            yield found
        finally:
            found += [str(w.message) for w in caught if issubclass(w.category, FaceSkippedWarning)]
    for w in caught:
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)


def read_mesh(path: str | os.PathLike) -> TriMesh:
    """Read an OBJ, PLY, STL, OFF, glTF, GLB, VTK, VTU, Gmsh MSH, Abaqus INP or Nastran BDF file into a `TriMesh`."""
    if _suffix(path) not in _MESH_SUFFIXES:
        raise FileFormatError(f"{path}: unknown mesh file suffix {_suffix(path)!r}; "
                              f"expected one of {', '.join(MESH_SUFFIXES)}")
    check_readable(path)
    from . import _meshfile
    return _meshfile.read(path)


def read(path: str | os.PathLike) -> Shell | TriMesh:
    """Read a CAD file into a `Shell` or a mesh file into a `TriMesh`, by suffix."""
    if _suffix(path) in _MESH_SUFFIXES:
        return read_mesh(path)
    return read_shell(path)


def write_shell(shell: Shell, path: str | os.PathLike) -> None:
    """Write a `Shell` as STEP (.step/.stp), Open CASCADE BREP (.brep) or VDAFS (.vda)."""
    _cad_module(path).write(shell, path)


def write_mesh(mesh: TriMesh, path: str | os.PathLike) -> None:
    """Write a `TriMesh` as OBJ, PLY, STL, OFF, glTF, GLB, VTK, VTU, MSH, INP or BDF/NAS, by suffix."""
    if _suffix(path) not in _MESH_SUFFIXES:
        raise FileFormatError(f"{path}: unknown mesh file suffix {_suffix(path)!r}; "
                              f"expected one of {', '.join(MESH_SUFFIXES)}")
    from . import _meshfile
    _meshfile.write(mesh, path)


def from_occ(obj, *, name: str = "") -> Shell:
    """A `Shell` from an OCP ``TopoDS_Shape``, a CadQuery or build123d object (see `trimsurf.io._shape.from_occ`)."""
    from ._shape import from_occ as _impl
    return _impl(obj, name=name)


def to_occ(shell, *, sew_tolerance: float | None = None):
    """The Open CASCADE ``TopoDS_Shape`` of a `Shell` (see `trimsurf.io._shape.to_occ`)."""
    from ._shape import to_occ as _impl
    return _impl(shell, sew_tolerance=sew_tolerance)


def occ_mesh_faces(shell: Shell, *, linear_deflection: float, angular_deflection: float = 0.5) -> list[TriMesh]:
    """Mesh every face of `shell` with Open CASCADE's ``BRepMesh_IncrementalMesh``, one `TriMesh` per face.

    See `trimsurf.io._occ._mesh.occ_mesh_faces` (uv from Open CASCADE's UV
    nodes, triangles oriented with the face's outward normal).
    """
    from ._occ._mesh import occ_mesh_faces as _impl
    return _impl(shell, linear_deflection=linear_deflection, angular_deflection=angular_deflection)

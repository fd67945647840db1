"""Mesh files: OBJ, PLY, STL, OFF, glTF/GLB through trimesh; VTK, VTU, Gmsh MSH, Abaqus INP, Nastran through meshio.

What each format keeps
----------------------

======  =============================  ==========  ===============================
format  coordinates on write           uv          face_id
======  =============================  ==========  ===============================
OBJ     text, 17 significant digits    ``vt``      not stored
        of the largest coordinate
PLY     binary little-endian float64   ``s, t``    face property ``face_id``
STL     binary float32                 --          --
OFF     text, as OBJ                   --          --
GLB     float32 (glTF accessor)        TEXCOORD_0  --
glTF    float32, buffers embedded      TEXCOORD_0  --
VTK     legacy 4.2 binary float64      ``uv``      cell data ``face_id``
VTU     XML, zlib binary float64       ``uv``      cell data ``face_id``
MSH     Gmsh 4.1 binary float64        --          --
INP     Abaqus text ``%.16e`` (exact)  --          --
        elements ``S3`` (shell)
BDF     Nastran GRID* large field:     --          PSHELL id ``face_id + 1``
NAS     11-12 significant digits
        (16 columns), CTRIA3
======  =============================  ==========  ===============================

The meshio formats (meshio 5.3.5) keep vertices (order and float64 bits) and
triangles exactly, except Nastran, whose 16-column fields hold 11 to 12
significant digits: writing it warns (`TrimsurfWarning`) with the largest
coordinate change when one occurs. On reading, ``triangle`` cells are kept,
``quad`` cells split into two triangles (0, 1, 2), (0, 2, 3), vertex and line
cells dropped, and other cells of dimension 2 or 3 (polygons, tetrahedra,
...) dropped with a `TrimsurfWarning`; all points are kept in file order.
meshio 5.3.5's Nastran writer fails on a coordinate whose 12-digit form
needs more than 16 columns (any negative one, e.g.): trimsurf gives it a
formatter that shortens such a number to fit.

Reading
-------
Files are loaded with ``process=False`` so the vertex order and duplicate
vertices of the file are kept; quads and polygons are triangulated by trimesh
(OFF lists triangles before triangulated polygons); a file with several
geometries (OBJ objects, glTF nodes) is concatenated into one mesh with the
node transforms applied. STL stores every triangle with its own three corners,
so for STL only, vertices with bit-identical coordinates are merged (in order
of first occurrence); a triangle with two equal corners then repeats an index
and is rejected as degenerate.

OBJ objects and groups sharing a material (or with none) come back in file
order; an OBJ whose faces use several materials comes back grouped by
material. An OBJ keeps its per-vertex uv when every ``v`` has exactly one ``vt``. When
``vt`` indices differ from ``v`` indices (uv seams), the vertex order of the
file is kept and the uv are dropped with a `TrimsurfWarning`.

Bad files raise `MeshReadError` (cannot be parsed, no triangles) or the
`MeshError` kind that `TriMesh` raises (NaN or infinite coordinates, or coordinates beyond
``COORDINATE_LIMIT`` = 1e12, indices out of range,
repeated indices: `DegenerateError`), always naming the file. Triangles of
zero area with distinct indices are read; `trimsurf.quality` reports them.

Writing
-------
The whole file is encoded in memory first, then written to a temporary file
beside the target and renamed, so a failed write leaves no file. PLY is
written by hand (trimesh 4.8.3 writes PLY coordinates as float32); every
other format through trimesh's exporters.
"""

from __future__ import annotations

import contextlib
import io
import logging
import math
import os
import re
import threading
import warnings
from pathlib import Path

import numpy as np

from ..errors import InputError, MeshError, MeshReadError, TrimsurfWarning
from ..model import TriMesh
from ._atomic import atomic_path

__all__ = ["read", "write", "FORMATS"]

FORMATS = {".obj": "OBJ", ".ply": "PLY", ".stl": "STL", ".off": "OFF", ".gltf": "glTF", ".glb": "GLB",
           ".vtk": "VTK", ".vtu": "VTU", ".msh": "Gmsh MSH", ".inp": "Abaqus INP", ".bdf": "Nastran BDF",
           ".nas": "Nastran"}
#: suffix -> meshio file format of the formats written and read through meshio
MESHIO_FORMATS = {".vtk": "vtk", ".vtu": "vtu", ".msh": "gmsh", ".inp": "abaqus", ".bdf": "nastran",
                  ".nas": "nastran"}
_V_LINE = re.compile(rb"^[ \t]*v[ \t]", re.MULTILINE)
_VT_LINE = re.compile(rb"^[ \t]*vt[ \t]", re.MULTILINE)


@contextlib.contextmanager
def _quiet_trimesh():
    """Silence trimesh's log records and numpy warnings raised inside it."""
    logger = logging.getLogger("trimesh")
    level = logger.level
    logger.setLevel(logging.CRITICAL + 1)
    try:
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")
            yield
    finally:
        logger.setLevel(level)


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if len(text) <= 200 else text[:197] + "..."


def _format(path: str | os.PathLike, error=MeshReadError) -> str:
    suffix = Path(path).suffix.lower()
    if suffix not in FORMATS:
        raise error(f"{path}: unknown mesh file suffix {suffix!r}; expected one of {', '.join(FORMATS)}")
    return suffix


# -- reading -------------------------------------------------------------------

def _load(p: Path, suffix: str):
    """(trimesh.Trimesh, notes for warnings, whether its uv are per file vertex); inside `_quiet_trimesh`."""
    import trimesh

    notes: list[str] = []
    kind = suffix[1:]
    if suffix == ".obj":
        raw = p.read_bytes()
        n_v = len(_V_LINE.findall(raw))
        has_vt = _VT_LINE.search(raw) is not None
        # group_material merges the object chunks into one geometry in file order (ungrouped chunks come
        # back reversed and, with maintain_order, each with a copy of all preceding vertices)
        common = dict(file_type="obj", process=False, force="mesh", group_material=True, skip_materials=True)
        mesh = trimesh.load(str(p), maintain_order=False, **common)
        if len(mesh.vertices) != n_v:
            # trimesh split vertices at uv/normal seams or dropped unused ones: reload in file order
            ordered = trimesh.load(str(p), maintain_order=True, **common)
            if len(ordered.vertices) <= n_v:
                mesh = ordered
                if has_vt:
                    notes.append("per-vertex uv dropped: vt indices differ from v indices (uv seams) "
                                 "or some vertices are unused")
                return mesh, notes, False
            notes.append("vertex order not kept: trimesh split vertices at uv or normal seams")
        return mesh, notes, True
    if suffix == ".ply":
        return trimesh.load(str(p), file_type="ply", process=False, force="mesh", fix_texture=False), notes, True
    return trimesh.load(str(p), file_type=kind, process=False, force="mesh"), notes, True


def _merge_exact_duplicates(vertices: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Merge bit-identical vertices, keeping them in order of first occurrence."""
    if not len(vertices):
        return vertices, triangles
    _, first, inverse = np.unique(vertices, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first)
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return vertices[first[order]], rank[inverse.ravel()][triangles]


def _uv_of(mesh, n: int) -> np.ndarray | None:
    uv = getattr(getattr(mesh, "visual", None), "uv", None)
    if uv is None:
        return None
    uv = np.asarray(uv, dtype=np.float64)
    if uv.shape != (n, 2) or not np.all(np.isfinite(uv)):
        return None
    return uv


def _face_id_of(mesh, m: int) -> np.ndarray | None:
    raw = getattr(mesh, "metadata", {}).get("_ply_raw", {}).get("face", {}).get("data")
    if isinstance(raw, dict):
        raw = raw.get("face_id")
        return None if raw is None or len(np.ravel(raw)) != m else np.asarray(raw).astype(np.int64).ravel()
    if not isinstance(raw, np.ndarray) or raw.dtype.names is None or "face_id" not in raw.dtype.names:
        return None
    fid = np.asarray(raw["face_id"]).astype(np.int64).ravel()
    return fid if len(fid) == m else None


#: largest coordinate magnitude accepted from a file (model units): beyond it squared distances, areas and
#: curvatures lose all precision or overflow (the issue's 1e300 meshes); 1e12 mm is a million km
COORDINATE_LIMIT = 1e12


def _check_coordinates(path, vertices: np.ndarray, *, per_triangle: bool = False) -> None:
    """Raise `MeshError` naming the first vertex with a non-finite coordinate or one beyond `COORDINATE_LIMIT`."""
    with np.errstate(all="ignore"):
        bad = ~(np.abs(vertices) <= COORDINATE_LIMIT).all(axis=1)   # NaN compares False
    if not bad.any():
        return
    i = int(np.argmax(bad))
    what = f"triangle {i // 3}" if per_triangle else f"vertex {i}"
    value = vertices[i][~(np.abs(vertices[i]) <= COORDINATE_LIMIT)][0]
    if np.isfinite(value):
        raise MeshError(f"{path}: {what} has coordinate {value:.3g}, beyond the supported magnitude "
                        f"{COORDINATE_LIMIT:g}; {int(bad.sum())} vertices are out of range")
    raise MeshError(f"{path}: {what} has a non-finite coordinate ({value}); {int(bad.sum())} vertices are bad")


def read(path: str | os.PathLike) -> TriMesh:
    """Read an OBJ, PLY, STL, OFF, glTF or GLB file into a `TriMesh`.

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    TriMesh
        Vertices in file order (STL: exact duplicates merged), triangles
        (polygons triangulated), per-vertex ``uv`` when the file has one per
        vertex (OBJ ``vt``, PLY ``s t``, glTF TEXCOORD_0), ``face_id`` when a
        PLY file has a ``face_id`` face property.

    Raises
    ------
    MeshReadError
        Unknown suffix, missing or empty file, a file trimesh cannot parse,
        or a file with no triangles.
    MeshError, DegenerateError
        NaN coordinates, indices out of range, a triangle repeating a vertex.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     p = pathlib.Path(folder) / "t.off"
    ...     _ = p.write_text("OFF\\n3 1 0\\n0 0 0\\n1 0 0\\n0 1 0\\n3 0 1 2\\n")
    ...     read(p).triangles.tolist()
    [[0, 1, 2]]
    """
    suffix = _format(path)
    name = FORMATS[suffix]
    p = Path(path)
    if not p.is_file():
        raise MeshReadError(f"{path}: no such file")
    if p.stat().st_size == 0:
        raise MeshReadError(f"{path}: file is empty")
    if suffix in MESHIO_FORMATS:
        return _read_meshio(p, path, suffix)
    with _quiet_trimesh():
        try:
            mesh, notes, keep_uv = _load(p, suffix)
            vertices = np.array(mesh.vertices, dtype=np.float64)
            triangles = np.array(getattr(mesh, "faces", np.zeros((0, 3))), dtype=np.int64).reshape(-1, 3)
            uv = _uv_of(mesh, len(vertices)) if keep_uv else None
            face_id = _face_id_of(mesh, len(triangles)) if suffix == ".ply" else None
        except Exception as exc:  # trimesh raises anything: ValueError, IndexError, KeyError, OSError, ...
            raise MeshReadError(f"{path}: cannot read {name} file: {_one_line(exc)}") from exc
    if not len(vertices):
        raise MeshReadError(f"{path}: no triangle mesh found in {name} file "
                            "(malformed, truncated, no faces, or a point cloud)")
    if not len(triangles):
        raise MeshReadError(f"{path}: {name} file holds {len(vertices)} vertices and no triangles")
    _check_coordinates(path, vertices, per_triangle=suffix == ".stl")
    if suffix == ".stl":
        vertices, triangles = _merge_exact_duplicates(vertices, triangles)
    for note in notes:
        warnings.warn(f"{path}: {note}", TrimsurfWarning, stacklevel=2)
    try:
        return TriMesh(vertices, triangles, uv=uv, face_id=face_id)
    except MeshError as exc:
        raise type(exc)(f"{path}: {exc}") from exc


# -- writing -------------------------------------------------------------------

def _text_digits(*arrays: np.ndarray | None) -> int:
    """Decimals for fixed-point text so the largest magnitude keeps 17 significant digits."""
    digits = 1
    for a in arrays:
        if a is None or not a.size:
            continue
        big = float(np.max(np.abs(a)))
        if big > 0:
            digits = max(digits, 17 - math.floor(math.log10(big)))
    return digits


def _to_trimesh(mesh: TriMesh):
    import trimesh
    from trimesh.visual import TextureVisuals

    visual = TextureVisuals(uv=np.array(mesh.uv)) if mesh.uv is not None else None
    return trimesh.Trimesh(np.array(mesh.vertices), np.array(mesh.triangles), visual=visual, process=False,
                           validate=False)


def _encode_ply(mesh: TriMesh) -> bytes:
    """Binary little-endian PLY with float64 coordinates (and s, t; face_id)."""
    n, m = mesh.n_vertices, mesh.n_triangles
    vfields = [("xyz", "<f8", (3,))]
    vprops = ["property double x", "property double y", "property double z"]
    if mesh.uv is not None:
        vfields.append(("st", "<f8", (2,)))
        vprops += ["property double s", "property double t"]
    ffields = [("count", "u1"), ("index", "<i4", (3,))]
    fprops = ["property list uchar int vertex_indices"]
    if mesh.face_id is not None:
        ffields.append(("face_id", "<i4"))
        fprops.append("property int face_id")
    if n >= 2 ** 31:
        raise MeshError(f"PLY writer: {n} vertices exceed the int32 index range")
    vdata = np.zeros(n, dtype=vfields)
    vdata["xyz"] = mesh.vertices
    if mesh.uv is not None:
        vdata["st"] = mesh.uv
    fdata = np.zeros(m, dtype=ffields)
    fdata["count"] = 3
    fdata["index"] = mesh.triangles
    if mesh.face_id is not None:
        fdata["face_id"] = mesh.face_id
    header = "\n".join(["ply", "format binary_little_endian 1.0", "comment written by trimsurf",
                        f"element vertex {n}", *vprops, f"element face {m}", *fprops, "end_header", ""])
    return header.encode("ascii") + vdata.tobytes() + fdata.tobytes()


def _encode(mesh: TriMesh, suffix: str) -> bytes:
    if suffix == ".ply":
        return _encode_ply(mesh)
    import trimesh

    with _quiet_trimesh():
        tm = _to_trimesh(mesh)
        if suffix == ".obj":
            text = trimesh.exchange.obj.export_obj(
                tm, include_normals=False, include_color=False, include_texture=mesh.uv is not None,
                write_texture=False, digits=_text_digits(mesh.vertices, mesh.uv), header=None)
            lines = [ln for ln in text.splitlines() if not ln.startswith(("mtllib", "usemtl"))]
            return ("# written by trimsurf\n" + "\n".join(lines).strip() + "\n").encode("ascii")
        if suffix == ".off":
            return trimesh.exchange.off.export_off(tm, digits=_text_digits(mesh.vertices)).encode("ascii")
        if suffix == ".stl":
            return trimesh.exchange.stl.export_stl(tm)
        if suffix == ".glb":
            return trimesh.exchange.gltf.export_glb(trimesh.Scene(tm), include_normals=False)
        files = trimesh.exchange.gltf.export_gltf(trimesh.Scene(tm), include_normals=False, embed_buffers=True)
        (data,) = files.values()
        return data


def write(mesh: TriMesh, path: str | os.PathLike) -> None:
    """Write a `TriMesh` as OBJ, PLY, STL, OFF, glTF or GLB, chosen by the suffix of `path`.

    Parameters
    ----------
    mesh : TriMesh
        Must have at least one triangle.
    path : str or os.PathLike

    Raises
    ------
    MeshError
        `mesh` is not a `TriMesh` or has no triangles, or the encoder failed.
    MeshReadError
        Unknown suffix.

    Notes
    -----
    See the module docstring for what each format keeps and its precision.
    Nothing is written when encoding fails.
    """
    suffix = _format(path)
    if not isinstance(mesh, TriMesh):
        raise MeshError(f"{path}: expected a TriMesh to write; got {type(mesh).__name__}")
    if not mesh.n_triangles:
        raise MeshError(f"{path}: mesh has no triangles; nothing to write")
    if suffix in MESHIO_FORMATS:
        _write_meshio(mesh, path, suffix)
        return
    try:
        data = _encode(mesh, suffix)
    except InputError:
        raise
    except Exception as exc:
        raise MeshError(f"{path}: cannot encode {FORMATS[suffix]}: {_one_line(exc)}") from exc
    with atomic_path(path) as tmp:
        Path(tmp).write_bytes(data)


# -- meshio formats ------------------------------------------------------------

_MESHIO_LOCK = threading.Lock()


@contextlib.contextmanager
def _quiet_meshio():
    """meshio prints its warnings on stderr (rich): keep them, and numpy's, out of the caller's output."""
    with contextlib.redirect_stderr(io.StringIO()), contextlib.redirect_stdout(io.StringIO()), \
            warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        yield


def _read_meshio(p: Path, path, suffix: str) -> TriMesh:
    import meshio

    name = FORMATS[suffix]
    with _quiet_meshio():
        try:
            # the format's own reader: meshio.read prints and calls sys.exit(1) on a ReadError
            m = getattr(meshio, MESHIO_FORMATS[suffix]).read(str(p))
        except (Exception, SystemExit) as exc:  # ReadError, ValueError, IndexError, struct.error, ...
            raise MeshReadError(f"{path}: cannot read {name} file: {_one_line(exc)}") from exc
    vertices = np.array(m.points, dtype=np.float64)  # native byte order (legacy VTK is big-endian)
    if vertices.ndim != 2 or vertices.shape[1] not in (2, 3):
        raise MeshReadError(f"{path}: {name} file holds points of shape {vertices.shape}; expected (n, 3)")
    if vertices.shape[1] == 2:
        vertices = np.column_stack([vertices, np.zeros(len(vertices))])
    pieces, fids, dropped = [], [], {}
    fid_data = m.cell_data.get("face_id") if suffix in (".vtk", ".vtu") else (
        m.cell_data.get("nastran:ref") if MESHIO_FORMATS[suffix] == "nastran" else None)
    for k, block in enumerate(m.cells):
        data = np.asarray(block.data, dtype=np.int64)
        fid = None if fid_data is None else np.asarray(fid_data[k]).astype(np.int64).ravel()
        if suffix not in (".vtk", ".vtu") and fid is not None:
            fid = fid - 1  # Nastran property ids: face_id + 1
        if block.type == "triangle":
            pieces.append(data.reshape(-1, 3))
            fids.append(fid)
        elif block.type == "quad":
            q = data.reshape(-1, 4)
            pieces.append(np.stack([q[:, [0, 1, 2]], q[:, [0, 2, 3]]], axis=1).reshape(-1, 3))
            fids.append(None if fid is None else np.repeat(fid, 2))
        elif getattr(block, "dim", 0) >= 2:
            dropped[block.type] = dropped.get(block.type, 0) + len(data)
    if dropped:
        what = ", ".join(f"{n} {t}" for t, n in dropped.items())
        warnings.warn(f"{path}: cells other than triangles and quads dropped: {what}", TrimsurfWarning,
                      stacklevel=3)
    if not len(vertices):
        raise MeshReadError(f"{path}: no points in {name} file")
    if not pieces or not sum(len(t) for t in pieces):
        raise MeshReadError(f"{path}: {name} file holds {len(vertices)} points and no triangles or quads")
    triangles = np.concatenate(pieces)
    face_id = np.concatenate(fids) if all(f is not None and len(f) == len(t) for f, t in zip(fids, pieces)) and \
        any(f is not None for f in fids) else None
    uv = None
    raw_uv = m.point_data.get("uv") if suffix in (".vtk", ".vtu") else None
    if raw_uv is not None:
        raw_uv = np.asarray(raw_uv, dtype=np.float64)
        if raw_uv.ndim == 2 and raw_uv.shape[0] == len(vertices) and raw_uv.shape[1] >= 2:
            uv = np.ascontiguousarray(raw_uv[:, :2])
    _check_coordinates(path, vertices)
    try:
        return TriMesh(vertices, triangles, uv=uv, face_id=face_id)
    except MeshError as exc:
        raise type(exc)(f"{path}: {exc}") from exc


def _nastran_float(value: float, length: int = 16) -> str:
    """meshio's Nastran real (``1.23456789012E+3``) shortened until it fits `length` columns."""
    for precision in range(11, 0, -1):
        out = np.format_float_scientific(value, exp_digits=1, precision=precision).replace("e", "E")
        if len(out) <= length:
            return out
    raise MeshError(f"Nastran writer: {value!r} does not fit a {length}-column field")


def _write_meshio(mesh: TriMesh, path, suffix: str) -> None:
    import meshio
    import meshio.nastran._nastran as nastran

    fmt = MESHIO_FORMATS[suffix]
    cell_data: dict = {}
    point_data: dict = {}
    if suffix in (".vtk", ".vtu"):
        if mesh.face_id is not None:
            cell_data["face_id"] = [np.asarray(mesh.face_id)]
        if mesh.uv is not None:  # legacy VTK vectors have 3 components
            point_data["uv"] = np.column_stack([mesh.uv, np.zeros(len(mesh.uv))]) if suffix == ".vtk" else mesh.uv
    if fmt == "nastran" and mesh.face_id is not None:
        cell_data["nastran:ref"] = [np.asarray(mesh.face_id) + 1]
    m = meshio.Mesh(np.asarray(mesh.vertices), [("triangle", np.asarray(mesh.triangles))], point_data=point_data,
                    cell_data=cell_data)
    moved = [0.0]

    def nastran_float(value, length=16):
        out = _nastran_float(value, length)
        moved[0] = max(moved[0], abs(float(out) - float(value)))
        return out

    with atomic_path(path) as tmp, _MESHIO_LOCK:
        try:
            with _quiet_meshio():
                if fmt == "vtk":
                    meshio.vtk.write(str(tmp), m, fmt_version="4.2", binary=True)
                elif fmt == "vtu":
                    meshio.vtu.write(str(tmp), m, binary=True, compression="zlib")
                elif fmt == "gmsh":
                    meshio.gmsh.write(str(tmp), m, fmt_version="4.1", binary=True)
                elif fmt == "abaqus":
                    m.cells[0].type = "S3"  # a shell element, not meshio's default R3D3 (rigid)
                    meshio.abaqus.write(str(tmp), m, translate_cell_names=False)
                else:
                    saved = nastran._float_to_nastran_string
                    nastran._float_to_nastran_string = nastran_float
                    try:
                        nastran.write(str(tmp), m, point_format="fixed-large", cell_format="fixed-small")
                    finally:
                        nastran._float_to_nastran_string = saved
        except InputError:
            raise
        except OSError:
            raise
        except Exception as exc:
            raise MeshError(f"{path}: cannot write {FORMATS[suffix]}: {_one_line(exc)}") from exc
    if moved[0] > 0:
        warnings.warn(f"{path}: Nastran fields hold 11-12 significant digits: coordinates moved by up to "
                      f"{moved[0]:.3g} (model units)", TrimsurfWarning, stacklevel=3)

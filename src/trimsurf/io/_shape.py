"""In-memory Open CASCADE shapes <-> `Shell`: plain OCP, CadQuery and build123d objects (duck typed).

`from_occ` converts exactly as the STEP reader does once the file is read
(`trimsurf.io._occ`): the shape must hold a face; every face's surface,
curves and vertices must be finite and within 1e10 in magnitude
(`_checks.check_shape_geometry`); the shape is converted with
``BRepBuilderAPI_NurbsConvert`` (on a copy: the caller's shape is not
touched) and copied face by face, a face that cannot be converted left out
with a `FaceSkippedWarning`. The difference: a file is read in a child
process (a malformed file can crash Open CASCADE), an in-memory shape is
converted in the calling process (it already lives there).

CadQuery and build123d are not dependencies: any object whose ``wrapped``
attribute is a ``TopoDS_Shape`` is accepted (CadQuery ``Shape``/``Solid``,
build123d ``Part``/``Solid``/``Compound``...), a CadQuery ``Workplane`` through
its ``vals()``, a build123d ``BuildPart`` through its ``part``, and a list or
tuple of any of these as one compound.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..errors import GeometryError, InputError
from ..model import Shell, TrimmedFace
from . import _occ

__all__ = ["from_occ", "to_occ"]


def _topods_class():
    from OCP.TopoDS import TopoDS_Shape

    return TopoDS_Shape


def _is_foreign_topods(obj) -> bool:
    """A TopoDS shape of another OCP build (a second copy of Open CASCADE's bindings in the process)."""
    return any(c.__name__.startswith("TopoDS_") for c in type(obj).__mro__)


def _unwrap(obj, what: str, depth: int = 0) -> list:
    """The TopoDS_Shape(s) `obj` holds; raises InputError naming `what`."""
    shape_cls = _topods_class()
    if isinstance(obj, shape_cls):
        return [obj]
    if depth > 4:
        raise InputError(f"{what}: nested too deeply to find an Open CASCADE shape")
    wrapped = getattr(obj, "wrapped", None)
    if wrapped is not None:
        if isinstance(wrapped, shape_cls):
            return [wrapped]
        if _is_foreign_topods(wrapped):
            raise InputError(f"{what}: its .wrapped {type(wrapped).__name__} comes from another OCP build "
                             f"(module {type(wrapped).__module__!r}) than trimsurf's cadquery-ocp; install one "
                             "Open CASCADE binding only (e.g. not cadquery-ocp-novtk beside cadquery-ocp)")
    if _is_foreign_topods(obj):
        raise InputError(f"{what}: {type(obj).__name__} comes from another OCP build (module "
                         f"{type(obj).__module__!r}) than trimsurf's cadquery-ocp")
    part = getattr(obj, "part", None)  # build123d BuildPart / BuildSketch builders
    if part is not None and part is not obj and not callable(part):
        return _unwrap(part, what, depth + 1)
    vals = getattr(obj, "vals", None)  # CadQuery Workplane
    if callable(vals):
        items = [v for v in vals() if getattr(v, "wrapped", None) is not None]
        if not items:
            raise InputError(f"{what}: the Workplane holds no shape (its stack has no solid, shell or face)")
        return [s for v in items for s in _unwrap(v, what, depth + 1)]
    if isinstance(obj, (list, tuple)):
        if not obj:
            raise InputError(f"{what}: empty sequence: no shape to convert")
        return [s for v in obj for s in _unwrap(v, what, depth + 1)]
    raise InputError(f"{what}: expected an Open CASCADE TopoDS_Shape, a CadQuery Workplane or Shape, a build123d "
                     f"object (anything with a .wrapped TopoDS_Shape) or a list of them; got {type(obj).__name__}")


def as_topods(obj, *, name: str = ""):
    """The one ``TopoDS_Shape`` `obj` stands for (several are put into one ``TopoDS_Compound``)."""
    what = name or type(obj).__name__
    return _occ.compound(_unwrap(obj, what))


def from_occ(obj, *, name: str = "") -> Shell:
    """A `Shell` from an in-memory Open CASCADE shape, CadQuery or build123d object.

    Parameters
    ----------
    obj : TopoDS_Shape, object with ``.wrapped``, CadQuery Workplane, build123d builder, or list of them
        The shape; a list (or a Workplane holding several solids) becomes one compound.
    name : str
        Name of the shell and of the object in messages (default: the type name).

    Returns
    -------
    Shell
        As `trimsurf.io.read_shell` returns it for the same shape written to
        STEP (one `TrimmedFace` per distinct face, the shared edges).

    Raises
    ------
    InputError
        `obj` holds no Open CASCADE shape, or one from another OCP build.
    GeometryError
        The shape is null or holds no face, has a number that is not finite
        or above 1e10 in magnitude (naming the face), Open CASCADE cannot
        convert it to B-splines, or no face can be converted.

    Warns
    -----
    FaceSkippedWarning
        A face that cannot be converted is left out (named in the message).

    Notes
    -----
    Runs in the calling process (a file read runs in a child process, see
    `trimsurf.io.read_shell`). The input shape is not modified.

    Examples
    --------
    >>> from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox
    >>> shell = from_occ(BRepPrimAPI_MakeBox(10.0, 20.0, 30.0).Shape(), name="box")
    >>> len(shell.faces), len(shell.edges), shell.is_closed()
    (6, 12, True)
    """
    what = name or type(obj).__name__
    shape = as_topods(obj, name=what)
    if shape.IsNull():
        raise GeometryError(f"{what}: the Open CASCADE shape is null")
    if _occ.count_faces(shape) == 0:
        raise GeometryError(f"{what}: the shape holds no faces ({shape.ShapeType().name.removeprefix('TopAbs_')})")
    from ._occ._checks import check_shape_geometry

    check_shape_geometry(shape, what, GeometryError)
    with np.errstate(all="ignore"):  # as in the reader's child process
        converted = _occ.nurbs_shape(shape, path=what, error=GeometryError)
        return _occ.shape_to_shell(converted, name=what, skip_bad_faces=True)


def to_occ(shell: Shell | TrimmedFace | Sequence[TrimmedFace], *, sew_tolerance: float | None = None):
    """The Open CASCADE shape of a `Shell`: what the STEP and BREP writers write.

    Parameters
    ----------
    shell : Shell, TrimmedFace or sequence of TrimmedFace
    sew_tolerance : float, optional
        As in `trimsurf.io._step.write` (faces without shared-edge topology are sewn).

    Returns
    -------
    TopoDS_Shape
        A solid when the shell is closed, a shell or a compound otherwise.
        Wrap it with ``cadquery.Shape.cast(shape)`` or
        ``build123d.Compound(shape)`` to use it there.

    Raises
    ------
    GeometryError
        Open CASCADE could not build the shape, or `shell` holds no faces.

    Warns
    -----
    TrimsurfWarning
        ``BRepCheck_Analyzer`` rejects the built shape (returned anyway).

    Examples
    --------
    >>> from trimsurf.samples import build_sample
    >>> shape = to_occ(build_sample("bspline_box"))
    >>> shape.ShapeType().name
    'TopAbs_SOLID'
    """
    from ._step import shape_for_writing

    if isinstance(shell, Shell):
        label = shell.name or "shell"
    else:
        label = "faces"
        if isinstance(shell, TrimmedFace):
            shell = [shell]
        if not isinstance(shell, Sequence) or not all(isinstance(f, TrimmedFace) for f in shell):
            raise InputError(f"to_occ: expected a Shell, a TrimmedFace or a sequence of TrimmedFace; got "
                             f"{type(shell).__name__}")
    return shape_for_writing(shell, label, sew_tolerance=sew_tolerance, stacklevel=4,
                             action="returning it anyway")

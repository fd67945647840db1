"""Exceptions raised by trimsurf.

Bad input raises :class:`InputError` or one of its kinds. The message names
the file (when there is one), the entity and what is wrong, in one line, so
the command line can print it as is and exit with status 2.
"""

from __future__ import annotations

__all__ = [
    "InputError",
    "FileFormatError",
    "StepReadError",
    "IgesReadError",
    "BrepReadError",
    "VdafsReadError",
    "MeshReadError",
    "MeshError",
    "NonManifoldError",
    "DegenerateError",
    "TrimLoopError",
    "GeometryError",
    "TrimsurfWarning",
    "FaceSkippedWarning",
]


class InputError(ValueError):
    """Input that trimsurf cannot work with (file, mesh, model or argument)."""


class FileFormatError(InputError):
    """A file that is empty, truncated, malformed or of an unknown format."""


class StepReadError(FileFormatError):
    """A STEP file Open CASCADE cannot read, or that holds no faces."""


class IgesReadError(FileFormatError):
    """An IGES file Open CASCADE cannot read, or that holds no faces."""


class BrepReadError(FileFormatError):
    """An Open CASCADE .brep file that cannot be read, or that holds no faces."""


class VdafsReadError(FileFormatError):
    """A VDAFS file that breaks the VDA-FS 2.0 layout or refers to missing entities."""


class MeshReadError(FileFormatError):
    """A mesh file that cannot be read."""


class MeshError(InputError):
    """A mesh with invalid content (NaN coordinates, bad indices, ...)."""


class NonManifoldError(MeshError):
    """A mesh with non-manifold edges or vertices where a 2-manifold is needed."""


class DegenerateError(MeshError):
    """Zero-area triangles, repeated indices or collapsed geometry."""


class TrimLoopError(InputError):
    """A trim loop that is open, self-intersecting or otherwise unusable."""


class GeometryError(InputError):
    """Invalid curve or surface data (knots, degrees, weights, control points)."""


class TrimsurfWarning(UserWarning):
    """Something the user should know that does not stop the work."""


class FaceSkippedWarning(TrimsurfWarning):
    """A face of a CAD file that could not be converted and was left out (the rest of the file is read)."""

"""trimsurf: move geometry between CAD and meshes with guarantees.

Layers (ARCHITECTURE.md): ``geom`` (pure maths) -> ``model`` (dataclasses) ->
``io`` -> ``quality`` -> capabilities -> ``viz`` -> ``samples`` -> ``cli``.
"""

from importlib.metadata import PackageNotFoundError, version as _version

try:
    __version__ = _version("trimsurf")
except PackageNotFoundError:  # running from a source tree
    __version__ = "0.0.0"

__all__ = ["__version__"]

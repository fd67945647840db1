"""trimsurf: move geometry between CAD and meshes with guarantees.

Layers (ARCHITECTURE.md): ``geom`` (pure maths) -> ``model`` (dataclasses) ->
``io`` -> ``quality`` -> capabilities -> ``viz`` -> ``samples`` -> ``cli``.
Subpackages load on first use, so ``import trimsurf as ts`` stays cheap:

>>> import trimsurf as ts
>>> ts.samples.build_sample("fender").faces[0].surface.degree_u
3
"""

from importlib import import_module
from importlib.metadata import PackageNotFoundError, version as _version

try:
    __version__ = _version("trimsurf")
except PackageNotFoundError:  # running from a source tree
    __version__ = "0.0.0"

_SUBPACKAGES = ("errors", "tolerance", "geom", "model", "io", "quality", "samples", "cli")

__all__ = ["__version__", *_SUBPACKAGES]


def __getattr__(name: str):
    if name in _SUBPACKAGES:
        return import_module(f".{name}", __name__)
    raise AttributeError(f"module 'trimsurf' has no attribute {name!r}")

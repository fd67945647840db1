"""trimsurf: move geometry between CAD and meshes with guarantees.

Layers (ARCHITECTURE.md): ``geom`` (pure maths) -> ``model`` (dataclasses) ->
``io`` -> ``quality`` -> capabilities -> ``viz`` -> ``samples`` -> ``cli``.
Subpackages load on first use, so ``import trimsurf as ts`` stays cheap:

>>> import trimsurf as ts
>>> ts.samples.build_sample("fender").faces[0].surface.degree_u
3
"""

from importlib import import_module

_SUBPACKAGES = ("errors", "tolerance", "geom", "model", "io", "quality", "samples", "cli")

__all__ = ["__version__", *_SUBPACKAGES]


def _version() -> str:
    """The installed distribution's version, looked up on first use (``importlib.metadata``: 30-60 ms,
    which the reader server, a ``python -m trimsurf.io._occ._worker`` process, does not need)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("trimsurf")
    except PackageNotFoundError:  # running from a source tree
        return "0.0.0"


def __getattr__(name: str):
    if name == "__version__":
        globals()["__version__"] = value = _version()
        return value
    if name in _SUBPACKAGES:
        return import_module(f".{name}", __name__)
    raise AttributeError(f"module 'trimsurf' has no attribute {name!r}")

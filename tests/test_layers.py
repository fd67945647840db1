"""ARCHITECTURE.md "Layers": geom imports nothing of ours above it, model only geom (s27-prep's batched loop
polylines were left out at merge because model.trim imported tessellate inside a function: imports in
function bodies count too). Checked on the source text (ast), every import statement of every module."""

from __future__ import annotations

import ast
from pathlib import Path

import trimsurf

PKG = Path(trimsurf.__file__).resolve().parent
#: top-level modules of the package below every layer (helpers any layer may use)
BASE = {"errors", "tolerance", "_numba_load"}
#: the layers each of these packages may import from (itself included)
ALLOWED = {"geom": {"geom"}, "model": {"model", "geom"}}
#: known exceptions, imported on use only: the notebook reprs of `TriMesh` (model/mesh.py) call viz
EXCEPTIONS = {("model/mesh.py", "viz")}


def _imported_packages(path: Path, layer: str, text: str | None = None) -> set:
    """The first-level trimsurf names `path` (or `text` as if it were that file) imports (relative or
    absolute, anywhere in the file)."""
    rel = path.relative_to(PKG)
    depth = len(rel.parts) - 1        # packages between trimsurf and the module
    out = set()
    for node in ast.walk(ast.parse(path.read_text() if text is None else text, str(path))):
        names = []
        if isinstance(node, ast.ImportFrom):
            if node.level == 0:
                names = [node.module or ""]
            elif node.level <= depth:
                names = [layer]           # within its own package
            else:
                up = node.level - depth - 1   # levels above trimsurf/ (0: trimsurf itself)
                assert up == 0, (path, node.level)
                names = [node.module] if node.module else [a.name for a in node.names]
                names = ["trimsurf." + n for n in names]
        elif isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        for n in names:
            if n.startswith("trimsurf."):
                out.add(n.split(".")[1])
            elif n == layer:
                out.add(layer)
    return out


def test_low_layers_import_nothing_above_them():
    bad = []
    seen = 0
    for layer, allowed in ALLOWED.items():
        for path in sorted((PKG / layer).rglob("*.py")):
            seen += 1
            rel = str(path.relative_to(PKG))
            for name in _imported_packages(path, layer) - allowed - BASE:
                if (rel, name) not in EXCEPTIONS:
                    bad.append((rel, name))
    assert seen > 10
    assert bad == [], "modules importing from layers above them"


def test_the_check_sees_function_body_imports():
    # the s27-prep case: model.trim importing tessellate inside a function is found
    src = PKG / "model" / "trim.py"
    assert "tessellate" not in _imported_packages(src, "model")
    text = src.read_text() + "\n\ndef _f():\n    from ..tessellate._line_kernels import x\n    import trimsurf.io\n"
    assert _imported_packages(src, "model", text) >= {"tessellate", "io", "geom"}
    assert _imported_packages(PKG / "geom" / "_nurbs_kernels.py", "geom") == {"_numba_load"}
    assert "geom" in _imported_packages(PKG / "model" / "nurbs.py", "model")     # `from .. import geom`

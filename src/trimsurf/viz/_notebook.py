"""Notebook display: reports as plain dicts and one-row tables, and the inline interactive viewer.

`repr_html` is what ``_repr_html_`` of `TriMesh` and of the results of
tessellate, join, certify and fit return: the page of `write_html`
(three.js inlined, meshes embedded, no network) inside an ``<iframe
srcdoc=...>``, and beside it a table of the report's key figures. The
lower layers (model, capabilities) import this module only when the method
is called.

`report_of` gives the report of such an object as a plain, JSON-ready dict;
`report_table` flattens reports into a list of one-level dicts (one per
object, nested keys joined with ``.``) that ``pandas.DataFrame`` accepts as
it is (pandas is not needed).
"""

from __future__ import annotations

import html
import math

import numpy as np

from ..errors import InputError
from ..model import Shell, TriMesh

__all__ = ["report_of", "report_table", "flat_row", "repr_html", "notebook_mesh"]

#: triangles of the perturbed faces shown for a certificate, per face
_CERTIFY_TRIANGLES_PER_FACE = 200
#: rows of key figures shown beside the viewer
_MAX_ROWS = 24


def _jsonable(value):
    from ..quality._results import jsonable

    return jsonable(value, arrays=True)


def mesh_report(mesh: TriMesh) -> dict:
    """Figures of a mesh: sizes, bounding box, topology (`topology_report`), triangle angles (`triangle_quality`)."""
    from ..quality import topology_report, triangle_quality

    lo, hi = mesh.bounding_box() if mesh.n_vertices else (np.zeros(3), np.zeros(3))
    report = {"kind": "mesh", "n_vertices": mesh.n_vertices, "n_triangles": mesh.n_triangles,
              "diagonal": mesh.diagonal(), "bounding_box": {"min": lo.tolist(), "max": hi.tolist()},
              "has_uv": mesh.uv is not None, "has_face_id": mesh.face_id is not None}
    topo = topology_report(mesh).as_dict()
    report.update({k: v for k, v in topo.items() if k not in report})
    if mesh.n_triangles:
        quality = triangle_quality(mesh).as_dict()
        report.update({k: quality[k] for k in ("min_angle_deg", "p5_min_angle_deg", "max_angle_deg",
                                               "max_radius_ratio", "n_zero_area")})
    return report


def report_of(obj) -> dict:
    """The report of a `TriMesh` or a capability result as a plain JSON-ready dict.

    TriMesh: `mesh_report`; TessellationResult, JoinResult: their ``report``;
    ShellCertificate: ``as_dict()``; FitResult: face, methods, grid,
    embedding figures and step times; a dict is returned converted.

    Raises
    ------
    InputError
        Any other object.
    """
    if isinstance(obj, dict):
        return _jsonable(obj)
    if isinstance(obj, TriMesh):
        return _jsonable(mesh_report(obj))
    kind = type(obj).__name__
    if kind == "ShellCertificate":
        return _jsonable(obj.as_dict())
    if kind in ("TessellationResult", "JoinResult"):
        return _jsonable(dict(obj.report))
    if kind == "FitResult":
        face = obj.face
        return _jsonable({"kind": "fit", "name": face.name, "embed_method": obj.embed_method,
                          "backmap_method": obj.backmap_method, "n_loops": len(face.loops),
                          "degree": [face.surface.degree_u, face.surface.degree_v],
                          "n_control_points": list(np.shape(face.surface.control_points)[:2]),
                          "n_vertices": int(len(obj.uv)), "embedding": obj.embedding.as_dict()
                          if hasattr(obj.embedding, "as_dict") else obj.embedding, "seconds": obj.seconds})
    raise InputError(f"no report for a {kind}: expected a TriMesh, a dict or a result of tessellate, join, "
                     "certify or fit")


def flat_row(report: dict, *, prefix: str = "") -> dict:
    """One row: the report's scalar values with nested keys joined by ``.``; short lists of scalars
    (up to 3, e.g. a point) as ``key.0``, ``key.1``, ...; longer lists (per-face details) left out.

    Examples
    --------
    >>> flat_row({"a": 1, "b": {"c": 2.5, "d": [1, 2, 3]}, "faces": [{"x": 1}] * 9})
    {'a': 1, 'b.c': 2.5, 'b.d.0': 1, 'b.d.1': 2, 'b.d.2': 3}
    """
    row: dict = {}
    for key, value in report.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            row.update(flat_row(value, prefix=name + "."))
        elif isinstance(value, (list, tuple)):
            if len(value) <= 3 and all(v is None or isinstance(v, (str, bool, int, float)) for v in value):
                row.update({f"{name}.{i}": v for i, v in enumerate(value)})
        elif value is None or isinstance(value, (str, bool, int, float)):
            row[name] = value
    return row


def report_table(*objs) -> list[dict]:
    """A list of one-level dicts, one per object (`report_of` flattened by `flat_row`): ``pandas.DataFrame(rows)``.

    Examples
    --------
    >>> from trimsurf.samples import build_sample
    >>> rows = report_table(build_sample("octahedron"))
    >>> len(rows), rows[0]["n_triangles"], rows[0]["is_watertight"]
    (1, 8, True)
    """
    return [flat_row(report_of(o)) for o in objs]


def notebook_mesh(obj) -> tuple[TriMesh, str]:
    """The mesh the viewer shows for `obj`, and its caption."""
    if isinstance(obj, TriMesh):
        return obj, "mesh"
    kind = type(obj).__name__
    if kind == "TessellationResult":
        return obj.mesh, "tessellation"
    if kind == "JoinResult":
        return obj.mesh, "joined mesh"
    if kind == "ShellCertificate":
        return (obj.well_defined_mesh(n_triangles_per_face=_CERTIFY_TRIANGLES_PER_FACE),
                "well-defined (perturbed) faces")
    if kind == "FitResult":
        from ..tessellate import tessellate_shell

        shell = Shell.from_faces([obj.face], name=obj.face.name)
        return tessellate_shell(shell, measure=False).mesh, "fitted trimmed face (tessellated)"
    raise InputError(f"nothing to show for a {kind}")


def _cell(value) -> str:
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return f"{value:.6g}" if math.isfinite(value) else str(value)
    return html.escape(str(value))


def _key_rows(row: dict) -> list[tuple[str, object]]:
    """The figures shown: counts, checks and measured maxima first, per-step times and settings last."""
    def rank(key: str) -> int:
        if key.startswith(("seconds", "timings", "settings", "parameters")) or ".faces" in key:
            return 2
        if "." in key:
            return 1
        return 0
    items = sorted(row.items(), key=lambda kv: rank(kv[0]))
    return [(k, v) for k, v in items if not isinstance(v, str) or len(v) < 200][:_MAX_ROWS]


def repr_html(obj, *, height_px: int = 420) -> str:
    """The notebook HTML of `obj`: the interactive viewer inline (iframe srcdoc, offline) and the key figures.

    Examples
    --------
    >>> from trimsurf.samples import build_sample
    >>> text = repr_html(build_sample("octahedron"))
    >>> text.startswith("<div") and "<iframe" in text and "n_triangles" in text
    True
    """
    from ._html import html_page

    mesh, caption = notebook_mesh(obj)
    report = report_of(obj)
    title = report.get("name") or type(obj).__name__
    rows = "".join(f"<tr><td style='text-align:left;padding:0 6px'>{html.escape(k)}</td>"
                   f"<td style='text-align:right;padding:0 6px'>{_cell(v)}</td></tr>"
                   for k, v in _key_rows(flat_row(report)))
    if mesh.n_triangles:
        page = html_page(mesh, titles=(caption,), title=str(title))
        page = page.replace('<details id="panel" open>', '<details id="panel">', 1)  # controls folded: small view
        viewer = (f"<iframe srcdoc=\"{html.escape(page, quote=True)}\" style='flex:1 1 480px;min-width:320px;"
                  f"height:{int(height_px)}px;border:1px solid #ccc' title='trimsurf viewer'></iframe>")
    else:
        viewer = "<p>(no triangles to show)</p>"
    head = html.escape(type(obj).__name__ if title == type(obj).__name__ else f"{type(obj).__name__}: {title}")
    return (f"<div class='trimsurf-repr' style='display:flex;flex-wrap:wrap;gap:8px;align-items:flex-start'>"
            f"{viewer}<div style='flex:0 1 360px;font-size:12px'><b>{head}</b><table>{rows}</table></div></div>")

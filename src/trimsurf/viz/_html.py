"""A self-contained interactive HTML page: three.js inlined, meshes embedded as gzip + base64 binary."""

from __future__ import annotations

import base64
import gzip
import json
import re
from importlib import resources
from pathlib import Path
from typing import Sequence

import numpy as np

from ..errors import InputError
from ..model import TriMesh
from ._camera import resolve_camera
from ._curvature import CURVATURE_KINDS, mesh_curvatures
from ._exact import refine_exact, refinement_level, unshare_faces
from ._render import _bounds, _check_mesh, curvature_range
from ._shading import HighlightOptions, ZebraOptions, auto_light, auto_stripe_count_mesh, vertex_normals

__all__ = ["write_html", "html_page", "HTML_MODES"]

HTML_MODES = ("zebra", "highlight", "curvature", "mesh")


def _asset(name: str) -> str:
    return resources.files(__package__).joinpath("_assets", name).read_text(encoding="utf-8")


def _b64(text: str) -> str:
    return base64.b64encode(text.encode("utf-8")).decode("ascii")


def _mesh_blob(mesh: TriMesh, normals: np.ndarray, curv, origin: np.ndarray) -> bytes:
    """positions - origin f32 (3n) | normals int16 (3n) | pad to 4 | K, H, max|k| f32 (3n) | indices u32 (3m).

    Positions are stored relative to `origin` (the model's box centre), so
    float32 keeps their precision for models far from the coordinate origin.
    """
    n = mesh.n_vertices
    pos = (mesh.vertices - origin).astype("<f4").tobytes()
    nrm = np.clip(np.round(normals * 32767.0), -32767, 32767).astype("<i2").tobytes()
    pad = b"\0\0" if (6 * n) % 4 else b""
    c = np.column_stack([curv.gaussian, curv.mean, curv.max_abs])
    c = np.where(np.isfinite(c), c, 0.0).astype("<f4").tobytes()
    idx = mesh.triangles.astype("<u4").tobytes()
    return gzip.compress(pos + nrm + pad + c + idx, compresslevel=1, mtime=0)


def script_json(value) -> str:
    """`value` as JSON safe inside an HTML ``<script>`` element: ``<``, ``>``, ``&`` as ``\\u003c`` etc.

    Escaping only ``</`` is not enough: ``<!--<script>`` in a string switches the
    HTML parser into a state where ``</script>`` no longer ends the element.

    Examples
    --------
    >>> script_json({"title": "a<!--<script>.obj"})
    '{"title": "a\\\\u003c!--\\\\u003cscript\\\\u003e.obj"}'
    >>> json.loads(script_json({"title": "a<!--<script>.obj"}))["title"]
    'a<!--<script>.obj'
    """
    text = json.dumps(value)
    return text.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")


def write_html(meshes: TriMesh | Sequence[TriMesh], path, *, titles: Sequence[str] = (), title: str = "",
               mode: str = "zebra", exact=None, camera=None, n_stripes: float | None = None,
               stripe_angle_deg: float = 0.0, stripe_width: float = 0.5, light=None,
               shininess: float = 150.0, curvature: str = "mean") -> Path:
    """Write a self-contained interactive viewer page (opens offline from disk in any WebGL browser).

    Parameters
    ----------
    meshes : TriMesh or sequence of TriMesh
        Shown side by side, one camera for all (orbit with the mouse).
    path : str or Path
        Output ``.html`` (written atomically).
    titles : sequence of str
        One caption per mesh.
    title : str
        Page title.
    mode : {"zebra", "highlight", "curvature", "mesh"}
        Mode shown first; the page toggles between them, plus a wireframe overlay.
    exact : None or a sequence with one entry per mesh (None, Shell, TrimmedFace or callable)
        Reference surfaces as in `render_png`: that panel shows the mesh
        refined on the exact surface (to at least 100k triangles), with exact
        normals and curvatures.
    camera, n_stripes, stripe_angle_deg, stripe_width, light, shininess, curvature
        Starting values, as in `render_png` (the page has sliders for them).

    Returns
    -------
    Path

    Notes
    -----
    three.js 0.170 (MIT) and its OrbitControls are inlined as ``data:`` URLs
    in an import map: no network access. Each mesh is one gzip-compressed
    binary blob in base64 (float32 positions relative to the box centre
    ``origin`` in the page's metadata, int16 normals, float32
    curvatures K, H, max |k|, uint32 indices), inflated in the browser with
    ``DecompressionStream``. The vertex shader computes the zebra stripe
    coordinate from the per-vertex reflection vector, and the highlight
    colour, exactly like `render_png`; the rasterizer interpolates them
    linearly across triangles, so mesh artefacts show the same way.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from trimsurf.samples import build_sample
    >>> out = write_html(build_sample("octahedron"), pathlib.Path(tempfile.mkdtemp()) / "v.html")
    >>> "three.js" in out.read_text() or "importmap" in out.read_text()
    True
    """
    page = html_page(meshes, titles=titles, title=title, mode=mode, exact=exact, camera=camera, n_stripes=n_stripes,
                     stripe_angle_deg=stripe_angle_deg, stripe_width=stripe_width, light=light,
                     shininess=shininess, curvature=curvature)
    from ..io._atomic import atomic_path

    path = Path(path)
    with atomic_path(path) as tmp:
        tmp.write_text(page, encoding="utf-8")
    return path


def html_page(meshes: TriMesh | Sequence[TriMesh], *, titles: Sequence[str] = (), title: str = "",
              mode: str = "zebra", exact=None, camera=None, n_stripes: float | None = None,
              stripe_angle_deg: float = 0.0, stripe_width: float = 0.5, light=None,
              shininess: float = 150.0, curvature: str = "mean") -> str:
    """The page `write_html` writes, as a string (options as there); the notebook repr embeds it."""
    if isinstance(meshes, TriMesh):
        meshes = [meshes]
    meshes = list(meshes)
    if not meshes:
        raise InputError("meshes is empty: nothing to show")
    for i, m in enumerate(meshes):
        _check_mesh(m, f"meshes[{i}]")
    if mode not in HTML_MODES:
        raise InputError(f"mode must be one of {', '.join(HTML_MODES)}; got {mode!r}")
    if curvature not in CURVATURE_KINDS:
        raise InputError(f"curvature must be one of {', '.join(CURVATURE_KINDS)}; got {curvature!r}")
    zebra = ZebraOptions(n_stripes, stripe_angle_deg, stripe_width)
    hl = HighlightOptions(None if light is None else tuple(light), shininess)
    exacts = [None] * len(meshes) if exact is None else list(exact)
    if len(exacts) != len(meshes):
        raise InputError(f"exact must have one entry per mesh ({len(meshes)}); got {len(exacts)}")
    lo, hi, radius, points = _bounds(meshes)
    cam = resolve_camera(camera, lo, hi, aspect=(16 / 9) / len(meshes), radius=radius, points=points)
    if zebra.n_stripes is None:
        zebra = ZebraOptions(auto_stripe_count_mesh(meshes[0], cam, zebra.angle_deg),
                             zebra.angle_deg, zebra.width)
    if hl.light is None:
        hl = HighlightOptions(auto_light(meshes[0], cam), hl.shininess)
    titles = list(titles) + [""] * len(meshes)
    origin = 0.5 * (lo + hi)  # the page works relative to the box centre (float32 precision)
    blobs, metas = [], []
    for i, (m, ex) in enumerate(zip(meshes, exacts)):
        if ex is not None:
            # ~100k triangles or more: fine enough on screen, and the page stays a few MB
            m, normals, curv = refine_exact(m, ex, level=refinement_level(m.n_triangles, 100_000), curvature=True)
            if curv is None:
                curv = mesh_curvatures(m)
        else:
            m = unshare_faces(m)  # per-face normals, as CAD viewers shade a tessellation
            normals, curv = vertex_normals(m), mesh_curvatures(m)
        blob = base64.b64encode(_mesh_blob(m, normals, curv, origin)).decode("ascii")
        blobs.append(f'<script type="application/octet-stream" id="mesh-{i}">{blob}</script>')
        metas.append({"title": titles[i], "n_vertices": m.n_vertices, "n_triangles": m.n_triangles,
                      "exact": ex is not None,
                      "curvature_ranges": [list(curvature_range(getattr(curv, k), k)) for k in CURVATURE_KINDS]})
    dist = float(np.linalg.norm(np.subtract(cam.position, cam.focal_point)))
    lc = np.asarray(hl.light) / np.linalg.norm(hl.light)
    meta = {"mode": mode, "n_stripes": zebra.n_stripes, "stripe_angle_deg": zebra.angle_deg,
            "stripe_width": zebra.width, "shininess": hl.shininess,
            "light_az_el_deg": [float(np.degrees(np.arctan2(lc[0], lc[2]))), float(np.degrees(np.arcsin(lc[1])))],
            "curvature_kind": CURVATURE_KINDS.index(curvature),
            "origin": origin.tolist(),
            "camera": {"position": (np.subtract(cam.position, origin)).tolist(),
                       "focal_point": (np.subtract(cam.focal_point, origin)).tolist(),
                       "view_up": [float(x) for x in cam.frame()[1]], "view_angle_deg": cam.view_angle_deg,
                       "near": max(radius, 1e-12) * 1e-3, "far": dist + 20 * max(radius, 1e-12)},
            "meshes": metas}
    from .. import __version__ as version

    page = _asset("viewer.html")
    safe_title = (title or "trimsurf viewer").replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
    parts = {"__VERSION__": str(version), "__TITLE__": safe_title,
             "__THREE_B64__": _b64(_asset("three.module.min.js")), "__ORBIT_B64__": _b64(_asset("OrbitControls.js")),
             "__META__": script_json(meta), "__BLOBS__": "\n".join(blobs),
             "__VIEWER_JS__": _asset("viewer.js")}
    # one pass: a title or mesh name holding a placeholder's text is never replaced in turn
    return re.sub("|".join(re.escape(k) for k in parts), lambda m: parts[m.group(0)], page)

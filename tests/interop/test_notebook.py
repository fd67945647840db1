"""Notebook display: `_repr_html_` of meshes and results (inline offline viewer + key figures), report tables.

The browser test loads the reprs the way Jupyter shows them (HTML inserted in
a page) in headless Chromium and waits until every inline viewer has drawn;
it skips (with scripts/test's reason) or fails like tests/viz/test_html.py
when Chromium is missing.
"""

from __future__ import annotations

import html
import io
import json
import re

import numpy as np
import pytest

from tests.viz.test_html import CHROMIUM, CHROMIUM_ARGS, _need_chromium
from trimsurf.errors import InputError
from trimsurf.samples import build_sample, holed_sheet
from trimsurf.viz import report_of, report_table


@pytest.fixture(scope="module")
def results() -> dict:
    """One object of every kind that has a notebook repr (small samples: seconds)."""
    from trimsurf.certify import certify_shell
    from trimsurf.fit import fit_trimmed_face
    from trimsurf.join import join_shell, mesh_faces_independently
    from trimsurf.tessellate import tessellate_shell

    pair = build_sample("gap_pair")
    d = 5e-3 * pair.diagonal()
    return {
        "mesh": build_sample("octahedron"),
        "tessellate": tessellate_shell(build_sample("bspline_box")),
        "join": join_shell(pair, mesh_faces_independently(pair, d), deflection=d),
        "certify": certify_shell(pair),
        "fit": fit_trimmed_face(holed_sheet(max_area=600.0), embed_method="lscm", grid_shape=(10, 8)),
    }


def _page_of(text: str) -> str:
    """The viewer page inside the repr's iframe srcdoc."""
    m = re.search(r'<iframe srcdoc="([^"]*)"', text)
    assert m, "no inline viewer"
    return html.unescape(m.group(1))


def _shown_triangles(page: str) -> int:
    meta = json.loads(re.search(r'<script type="application/json" id="trimsurf-meta">(.*?)</script>', page,
                                re.S).group(1))
    return meta["meshes"][0]["n_triangles"]


@pytest.mark.parametrize("kind", ["mesh", "tessellate", "join", "certify", "fit"])
def test_repr_html_inlines_the_offline_viewer_and_the_figures(results, kind):
    obj = results[kind]
    text = obj._repr_html_()
    page = _page_of(text)
    # self-contained: no URL the page could load from the network
    assert not re.search(r"""(src|href)\s*=\s*["']https?:""", page)
    assert not re.search(r"""from\s+["']https?:""", page)
    assert '"three": "data:text/javascript;base64,' in page
    assert 'id="mesh-0"' in page
    assert "https://" not in text.split("<iframe")[0]
    # the figures beside it are the report's: every count shown is the report's value
    row = report_table(obj)[0]
    figures = dict(re.findall(r"<tr><td[^>]*>([^<]+)</td><td[^>]*>([^<]*)</td></tr>", text))
    assert len(figures) >= 8
    for key, shown in figures.items():
        value = row[html.unescape(key)]
        if isinstance(value, bool):
            assert shown == ("yes" if value else "no"), key
        elif isinstance(value, int):
            assert shown == str(value), key
    mesh_of = {"mesh": lambda o: o, "tessellate": lambda o: o.mesh, "join": lambda o: o.mesh}
    if kind in mesh_of:  # the viewer shows the delivered mesh (unshared per face for flat shading)
        assert _shown_triangles(page) == mesh_of[kind](obj).n_triangles
    else:
        assert _shown_triangles(page) > 100


@pytest.mark.parametrize("kind", ["mesh", "tessellate", "join", "certify", "fit"])
def test_report_table_is_one_flat_row_pandas_accepts(results, kind):
    obj = results[kind]
    rows = obj.to_table()
    assert isinstance(rows, list) and len(rows) == 1 and isinstance(rows[0], dict)
    assert rows[0] and all(isinstance(k, str) for k in rows[0])
    assert all(v is None or isinstance(v, (str, bool, int, float)) for v in rows[0].values())
    json.dumps(rows, allow_nan=False)  # JSON-ready: no NaN, no numpy scalars
    report = report_of(obj)
    json.dumps(report, allow_nan=False)
    try:
        import pandas
    except ImportError:  # not a dependency: the structure above is what DataFrame(list of dicts) needs
        return
    frame = pandas.DataFrame(rows)
    assert frame.shape == (1, len(rows[0]))


def test_report_table_of_several_and_bad_input(results):
    rows = report_table(results["mesh"], results["tessellate"], {"name": "x", "a": {"b": 1}})
    assert len(rows) == 3 and rows[2] == {"name": "x", "a.b": 1}
    assert rows[1]["triangles"] == results["tessellate"].mesh.n_triangles
    assert rows[0]["is_watertight"] is True and rows[0]["genus"] == 0
    with pytest.raises(InputError, match="no report for a str"):
        report_table("mesh.ply")


def _shot(locator) -> np.ndarray:
    from PIL import Image

    with Image.open(io.BytesIO(locator.screenshot())) as im:
        return np.asarray(im.convert("RGB"), dtype=np.int16)


def test_reprs_load_in_headless_chromium(results, tmp_path):
    _need_chromium()
    from playwright.sync_api import sync_playwright

    kinds = ["mesh", "tessellate", "fit"]
    body = "".join(f"<h3>{k}</h3>{results[k]._repr_html_()}" for k in kinds)
    path = tmp_path / "notebook.html"
    path.write_text(f"<!doctype html><html><body>{body}</body></html>", encoding="utf-8")
    errors: list[str] = []
    requests: list[str] = []
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        try:
            page = browser.new_page(viewport={"width": 1000, "height": 1600})
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.on("request", lambda r: requests.append(r.url))
            page.goto(path.as_uri())
            frames = [f for f in page.frames if f != page.main_frame]
            assert len(frames) == len(kinds)
            for frame in frames:
                frame.wait_for_function("document.body.dataset.ready === '1' || !!document.body.dataset.error",
                                        timeout=30_000)
                assert frame.evaluate("document.body.dataset.error || ''") == ""
            shots = [_shot(page.locator("iframe").nth(i)) for i in range(len(kinds))]
        finally:
            browser.close()
    assert not errors
    assert requests and all(u.startswith(("file:", "data:", "blob:", "about:")) for u in requests), requests
    bg = np.array([0xdc, 0xde, 0xe3])
    for kind, img in zip(kinds, shots):
        covered = np.mean(np.any(np.abs(img - bg) > 8, axis=2))  # the model covers part of the view
        assert covered > 0.05, (kind, covered)
        zebra = img.reshape(-1, 3)
        assert np.mean(np.all(zebra == 0, axis=1)) > 0.005 and np.mean(np.all(zebra == 255, axis=1)) > 0.005, kind

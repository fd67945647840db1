"""The interactive page: self-contained, and end to end in headless Chromium (Playwright)."""

from __future__ import annotations

import base64
import gzip
import io
import json
import os
import re
import shutil

import numpy as np
import pytest

from trimsurf.errors import InputError
from trimsurf.viz import write_html

from .conftest import icosphere

CHROMIUM = "/usr/bin/chromium"
CHROMIUM_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
                 "--disable-sync", "--no-first-run", "--use-angle=swiftshader", "--enable-unsafe-swiftshader"]


def test_page_is_self_contained_and_embeds_the_mesh(tmp_path):
    m = icosphere(2)
    page = write_html(m, tmp_path / "v.html", title="a <sphere>").read_text(encoding="utf-8")
    # no network: no http(s) URL is loaded (script src, link href, import) -- only data: URLs
    assert not re.search(r"""(src|href)\s*=\s*["']https?:""", page)
    assert not re.search(r"""from\s+["']https?:""", page)
    assert '"three": "data:text/javascript;base64,' in page
    assert "a &lt;sphere&gt;" in page
    meta = json.loads(re.search(r'<script type="application/json" id="trimsurf-meta">(.*?)</script>', page,
                                re.S).group(1))
    assert meta["meshes"][0]["n_triangles"] == m.n_triangles
    blob = re.search(r'<script type="application/octet-stream" id="mesh-0">(.*?)</script>', page, re.S).group(1)
    raw = gzip.decompress(base64.b64decode(blob))
    n, t = m.n_vertices, m.n_triangles
    pos = np.frombuffer(raw[:12 * n], "<f4").reshape(-1, 3)
    off = 18 * n + (2 if (6 * n) % 4 else 0) + 12 * n
    idx = np.frombuffer(raw[off:off + 12 * t], "<u4").reshape(-1, 3)
    np.testing.assert_allclose(pos + meta["origin"], m.vertices, atol=1e-6)  # float32, relative to the origin
    np.testing.assert_array_equal(idx, m.triangles)
    assert len(raw) == off + 12 * t


def test_bad_input(tmp_path):
    with pytest.raises(InputError, match="mode must be one of"):
        write_html(icosphere(1), tmp_path / "v.html", mode="scalars")
    with pytest.raises(InputError, match="empty"):
        write_html([], tmp_path / "v.html")
    assert not list(tmp_path.iterdir())


def _screenshot(page) -> np.ndarray:
    from PIL import Image

    with Image.open(io.BytesIO(page.locator("#view").screenshot())) as im:
        return np.asarray(im.convert("RGB"), dtype=np.int16)


def _need_chromium() -> None:
    """Skip with scripts/test's reason when it could not install chromium; fail when run without it."""
    if shutil.which(CHROMIUM) is not None:
        return
    reason = os.environ.get("TRIMSURF_BROWSER_SKIP")
    if reason:
        pytest.skip(f"{CHROMIUM} is missing: {reason}")
    pytest.fail(f"{CHROMIUM} is missing: run the tests with scripts/test (README), which installs Debian's "
                "chromium or says why it cannot")


def test_page_in_headless_chromium(tmp_path):
    _need_chromium()
    from playwright.sync_api import sync_playwright

    path = write_html([icosphere(1), icosphere(4)], tmp_path / "v.html", titles=("coarse sphere", "fine sphere"),
                      title="test", camera="+z")
    errors: list[str] = []
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        try:
            page = browser.new_page(viewport={"width": 800, "height": 500})
            page.on("pageerror", lambda e: errors.append(str(e)))
            requests: list[str] = []
            page.on("request", lambda r: requests.append(r.url))
            page.goto(path.as_uri())
            page.wait_for_function("document.body.dataset.ready === '1' || !!document.body.dataset.error",
                                   timeout=30_000)
            assert page.evaluate("document.body.dataset.error || ''") == ""
            page.locator("#panel summary").click()  # fold the control panel away from the pictures
            shots = {"zebra": _screenshot(page)}
            for mode in ("highlight", "curvature", "mesh"):
                page.locator("#panel summary").click()
                page.locator(f"input[name=mode][value={mode}]").check()  # the page's own toggle
                page.locator("#panel summary").click()
                shots[mode] = _screenshot(page)
            page.evaluate("window.trimsurfViewer.setMode('zebra'); window.trimsurfViewer.setWireframe(true)")
            shots["wireframe"] = _screenshot(page)
            page.evaluate("window.trimsurfViewer.setWireframe(false)")
            page.locator("#panel summary").click()
            page.locator("#stripes").fill("0.9")  # many more stripes
            page.locator("#panel summary").click()
            shots["stripes"] = _screenshot(page)
        finally:
            browser.close()
    assert not errors
    # offline: the page loads nothing but itself and its inlined data: URLs
    assert requests and all(u.startswith(("file:", "data:", "blob:")) for u in requests), requests
    bg = np.array([0xdc, 0xde, 0xe3])
    for name, img in shots.items():
        # not blank: the meshes cover a good part of the canvas, in more than one colour
        covered = np.mean(np.any(np.abs(img - bg) > 8, axis=2))
        assert covered > 0.1, (name, covered)
        assert len(np.unique(img.reshape(-1, 3), axis=0)) > 2, name
    zebra = shots["zebra"].reshape(-1, 3)
    assert np.mean(np.all(zebra == 0, axis=1)) > 0.03 and np.mean(np.all(zebra == 255, axis=1)) > 0.03
    names = list(shots)
    for i, a in enumerate(names):  # every switch changes the picture
        for b in names[i + 1:]:
            changed = np.mean(np.any(shots[a] != shots[b], axis=2))
            assert changed > 0.02, (a, b, changed)
    # curvature: the paper's red-to-blue colour map is on screen
    cur = shots["curvature"].reshape(-1, 3)
    assert np.mean((cur[:, 2] > cur[:, 0] + 60)) > 0.02


def test_far_from_origin_keeps_float32_precision(tmp_path):
    from trimsurf.model import TriMesh

    m = icosphere(2)
    far = TriMesh(m.vertices + [1e6, -2e6, 5e5], m.triangles)
    page = write_html(far, tmp_path / "v.html").read_text(encoding="utf-8")
    meta = json.loads(re.search(r'id="trimsurf-meta">(.*?)</script>', page, re.S).group(1))
    raw = gzip.decompress(base64.b64decode(re.search(r'id="mesh-0">(.*?)</script>', page, re.S).group(1)))
    pos = np.frombuffer(raw[:12 * m.n_vertices], "<f4").reshape(-1, 3)
    # stored relative to the box centre: float32 resolves ~1e-7 of the unit sphere, not ~0.1 of 2e6
    np.testing.assert_allclose(pos + np.asarray(meta["origin"]), far.vertices, atol=1e-6)


HOSTILE_TITLES = ("a<!--<script>.obj", "</script><script>document.body.dataset.error='x'</script>",
                  "__VIEWER_JS__ __BLOBS__ & <b>")


def _meta_text(page: str) -> str:
    m = re.search(r'<script type="application/json" id="trimsurf-meta">(.*?)</script>', page, re.S)
    assert m is not None
    return m.group(1)


def test_hostile_titles_stay_inside_their_json(tmp_path):
    """Issue 16 item 8: the embedded JSON escapes every '<' (as \\u003c), so no title can end or open a tag."""
    path = write_html([icosphere(1)] * len(HOSTILE_TITLES), tmp_path / "v.html", titles=HOSTILE_TITLES,
                      title="a<!--<script>")
    page = path.read_text(encoding="utf-8")
    meta = _meta_text(page)
    assert "<" not in meta and ">" not in meta and "\\u003c!--\\u003cscript\\u003e" in meta
    assert [m["title"] for m in json.loads(meta)["meshes"]] == list(HOSTILE_TITLES)
    # the page has exactly the template's script elements: one per mesh blob plus the fixed ones
    plain = write_html([icosphere(1)] * len(HOSTILE_TITLES), tmp_path / "p.html", titles=("a", "b", "c"))
    assert page.count("<script") == plain.read_text(encoding="utf-8").count("<script")
    # placeholders in a title are not expanded (the viewer's code appears once)
    assert page.count("trimsurfViewer =") == plain.read_text(encoding="utf-8").count("trimsurfViewer =")


def test_hostile_titles_page_runs_in_headless_chromium(tmp_path):
    _need_chromium()
    from playwright.sync_api import sync_playwright

    path = write_html([icosphere(1)] * len(HOSTILE_TITLES), tmp_path / "v.html", titles=HOSTILE_TITLES)
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        try:
            page = browser.new_page(viewport={"width": 400, "height": 300})
            errors: list[str] = []
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.goto(path.as_uri())
            page.wait_for_function("document.body.dataset.ready === '1' || !!document.body.dataset.error",
                                   timeout=30_000)
            assert page.evaluate("document.body.dataset.error || ''") == ""
            shown = page.evaluate("JSON.parse(document.getElementById('trimsurf-meta').textContent)"
                                  ".meshes.map(m => m.title)")
        finally:
            browser.close()
    assert not errors and shown == list(HOSTILE_TITLES)

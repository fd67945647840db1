"""``trimsurf demo``: outputs for every sample, summary.json, report.html, failures, the picture hook."""

from __future__ import annotations

import base64
import json
import re

import pytest

from trimsurf.cli import demo_steps, main
from trimsurf.cli.demo_steps import StepOutput, step
from trimsurf.samples import SAMPLES
from trimsurf.samples.gap_pair import GAP_REL

# a 1 x 1 PNG
_PNG = base64.b64decode("iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42mNk+M9QDwADhgGAWjR9aw"
                        "AAAABJRU5ErkJggg==")


@pytest.fixture(scope="module")
def demo_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("demo")
    rc = main(["--debug", "demo", "--out", str(out)])
    return rc, out, json.loads((out / "summary.json").read_text())


def test_demo_runs_every_sample_and_step(demo_run):
    rc, out, summary = demo_run
    assert summary["failed"] == [], summary["failed"]
    assert rc == 0
    assert list(summary["samples"]) == list(SAMPLES)
    for name, sec in summary["samples"].items():
        kind = SAMPLES[name].kind
        expected = ["build"] + [s.name for s in demo_steps.STEPS if kind in s.kinds]
        assert list(sec["steps"]) == expected
        for st in sec["steps"].values():
            assert st["status"] == "ok" and st["seconds"] >= 0
            assert st["warnings"] == [], (name, st["warnings"])      # e.g. BRepCheck rejecting a written face
            for f in st["files"]:
                assert (out / f).is_file() and (out / f).stat().st_size > 0
        assert (out / f"{name}.info.json").is_file()


def test_demo_figures_describe_the_samples(demo_run):
    _, out, summary = demo_run
    for name in ("fender", "hood", "gap_pair", "bspline_box"):
        back = summary["samples"][name]["steps"]["read_back"]["figures"]
        assert back["step_max_deviation_rel"] < 1e-8 and back["vda_max_deviation_rel"] < 1e-8
    box = summary["samples"]["bspline_box"]["steps"]["info"]["figures"]
    assert box["closed"] is True and box["faces"] == 6 and box["edges_shared"] == 12
    gap = summary["samples"]["gap_pair"]["steps"]["info"]["figures"]
    assert gap["problems"] == 2 and gap["max_edge_curve_gap"] > 0.5e-3 * gap["diagonal"]
    q = summary["samples"]["gap_pair"]["steps"]["quality"]["figures"]
    # the two faces' p-curve images miss b(t) on opposite sides: up to twice the documented gap apart
    assert GAP_REL * gap["diagonal"] < q["max_g0_gap"] <= 2.02 * GAP_REL * gap["diagonal"]
    q = summary["samples"]["bspline_box"]["steps"]["quality"]["figures"]
    assert q["max_g0_gap"] < 1e-9 * box["diagonal"] and q["orientation_consistent"] is True
    for name in ("octahedron", "s_cone", "holed_sheet"):
        q = summary["samples"][name]["steps"]["quality"]["figures"]
        assert q["self_intersections"] == 0 and q["min_angle_deg"] >= 30 - 1e-9
    cone = summary["samples"]["s_cone"]["steps"]["info"]["figures"]
    assert cone["n_boundary_loops"] == 1 and cone["euler_characteristic"] == 1
    info = json.loads((out / "holed_sheet.info.json").read_text())
    assert info["n_boundary_loops"] == 3 and info["euler_characteristic"] == -1


def test_report_html_has_a_section_per_sample(demo_run):
    _, out, summary = demo_run
    html = (out / "report.html").read_text()
    assert html.startswith("<!DOCTYPE html>") and html.rstrip().endswith("</html>")
    for name in SAMPLES:
        assert f'<h2 id="{name}">' in html
    assert "all passed" in html
    assert not re.search(r'<(script|link)[^>]+(src|href)="http', html)   # self-contained


def test_demo_reports_a_failed_step_and_embeds_pictures(monkeypatch, tmp_path, capsys):
    monkeypatch.setattr(demo_steps, "STEPS", list(demo_steps.STEPS))   # restored after the test

    @step("picture", kinds=("mesh",))
    def _picture(ctx):
        png = ctx.out("picture.png")
        png.write_bytes(_PNG)
        return StepOutput(figures={"pixels": 1}, files=[png], images=[png])

    @step("broken", kinds=("shell",))
    def _broken(ctx):
        raise ValueError("no luck\nat all")

    monkeypatch.setattr("trimsurf.cli.demo.STEPS", demo_steps.STEPS)
    rc = main(["demo", "--quick", "--out", str(tmp_path), "--sample", "octahedron", "--sample", "fender"])
    assert rc == 1
    err = capsys.readouterr().err
    assert "trimsurf: error: demo step 'broken' failed on sample 'fender': ValueError: no luck at all" in err
    assert "Traceback" not in err
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["failed"] == ["fender/broken"] and list(summary["samples"]) == ["octahedron", "fender"]
    assert summary["samples"]["fender"]["steps"]["broken"]["error"] == "ValueError: no luck at all"
    assert "read_back" not in summary["samples"]["fender"]["steps"]            # --quick skips slow steps
    # the picture hook: this step's PNG is in the sample's images (capability steps, e.g. viz, add their own)
    assert "octahedron.picture.png" in summary["samples"]["octahedron"]["images"]
    html = (tmp_path / "report.html").read_text()
    assert "data:image/png;base64," + base64.b64encode(_PNG).decode() in html
    assert 'class="failed"' in html


def test_step_names_are_unique():
    with pytest.raises(ValueError, match="registered twice"):
        step("info")(lambda ctx: StepOutput())


def test_demo_into_a_file_is_input_error(tmp_path, capsys):
    target = tmp_path / "file"
    target.write_text("x")
    assert main(["demo", "--out", str(target)]) == 2
    assert "is not a folder" in capsys.readouterr().err

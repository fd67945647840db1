"""Commands that take a model accept an embedded sample's name where a file is expected (`_common.sample_input`):
an existing path always wins; a name that is neither is one error line, exit 2, pointing to the samples' list."""

from __future__ import annotations

import json

import numpy as np
import pytest

from trimsurf.cli import main
from trimsurf.io import read_mesh
from trimsurf.samples import SAMPLES, build_sample
from trimsurf.tessellate import tessellate_shell


def _one_error_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("trimsurf: error: ") and "Traceback" not in err[0], err
    return err[0]


def test_tessellate_sample_name(tmp_path, capsys):
    out, rep = tmp_path / "pair.ply", tmp_path / "r.json"
    assert main(["tessellate", "folding_pair", "-o", str(out), "--report", str(rep)]) == 0
    entry = json.loads(rep.read_text())["inputs"][0]
    assert entry["input"] == "folding_pair" and entry["output"] == str(out)
    assert "folding_pair" in capsys.readouterr().out               # the table's row names the sample
    mesh = read_mesh(out)
    ref = tessellate_shell(build_sample("folding_pair")).mesh     # the sample itself, at the same defaults
    assert mesh.n_triangles == entry["triangles"] == ref.n_triangles > 0
    assert entry["faces_in"] == len(build_sample("folding_pair").faces)
    np.testing.assert_allclose(np.sort(mesh.vertices, axis=0), np.sort(ref.vertices, axis=0), rtol=0, atol=1e-12)
    assert entry["max_deviation"] <= entry["tolerance"]


def test_tessellate_sample_into_folder_with_a_file(shared_data, tmp_path, capsys):
    """A sample name and a file in one batch: the sample's mesh is named after it."""
    outdir = tmp_path / "meshes"
    assert main(["tessellate", "gap_pair", str(shared_data / "cad" / "occt__screw.step"), "-o", str(outdir)]) == 0
    assert sorted(p.name for p in outdir.iterdir()) == ["gap_pair.ply", "occt__screw.ply"]
    assert read_mesh(outdir / "gap_pair.ply").n_triangles > 0


@pytest.mark.parametrize("argv", [["tessellate", "fendr", "-o", "x.ply"],
                                  ["tessellate", "folding_pair", "fendr", "-o", "out"],
                                  ["info", "fendr"], ["fit", "fendr", "-o", "x.step"],
                                  ["join", "fendr", "-o", "x.ply"], ["certify", "fendr"],
                                  ["reconstruct", "fendr", "-o", "x.npz"], ["view", "fendr", "--png", "x.png"]])
def test_bad_name_one_line_exit_2(argv, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    line = _one_error_line(capsys)
    assert "fendr: no such file, and not a sample name" in line and "trimsurf samples --list" in line, line
    assert not list(tmp_path.iterdir())                          # nothing written, no folder made


@pytest.mark.parametrize("argv, needs", [(["tessellate", "octahedron", "-o", "x.ply"], "needs a CAD shell"),
                                         (["join", "octahedron", "-o", "x.ply"], "needs a CAD shell"),
                                         (["fit", "fender", "-o", "x.step"], "needs a mesh"),
                                         (["reconstruct", "hood", "-o", "x.npz"], "needs a mesh")])
def test_sample_of_the_other_kind(argv, needs, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    line = _one_error_line(capsys)
    assert f"{argv[1]}: sample is a" in line and needs in line, line
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("command", [["tessellate", "-o", "x.ply"], ["info"], ["fit", "-o", "x.step"],
                                     ["join", "-o", "x.ply"], ["certify"], ["reconstruct", "-o", "x.npz"],
                                     ["view", "--png", "x.png"]])
def test_existing_file_named_like_a_sample_is_read_as_the_file(command, tmp_path, capsys, monkeypatch):
    """A file called 'fender' (or 'octahedron' for the mesh commands) is the file, not the sample: it is no
    CAD/mesh file, so the command refuses it -- where the sample would have run."""
    monkeypatch.chdir(tmp_path)
    name = "octahedron" if command[0] in ("fit", "reconstruct") else "fender"
    (tmp_path / name).write_text("not a model\n")
    assert main([command[0], name, *command[1:]]) == 2
    line = _one_error_line(capsys)
    assert line.startswith(f"trimsurf: error: {name}: ") and "no such file" not in line and "sample is" not in line
    assert any(w in line for w in ("not a CAD file", "not a mesh file", "unknown file suffix")), line
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]


def test_existing_folder_named_like_a_sample_wins(shared_data, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "fender").mkdir()
    (tmp_path / "fender" / "screw.step").symlink_to(shared_data / "cad" / "occt__screw.step")
    assert main(["tessellate", "fender", "-o", "out", "--report", "r.json"]) == 0
    entry = json.loads((tmp_path / "r.json").read_text())["inputs"]
    assert [e["input"] for e in entry] == [str(tmp_path / "fender" / "screw.step").replace(str(tmp_path) + "/", "")]
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["screw.ply"]


@pytest.mark.parametrize("name", ["fender", "octahedron"])
def test_info_sample_name(name, capsys):
    assert main(["info", "--json", name]) == 0
    report = json.loads(capsys.readouterr().out)
    obj = build_sample(name)
    assert SAMPLES[name].kind in ("shell", "mesh")
    if SAMPLES[name].kind == "shell":
        assert report["n_faces"] == len(obj.faces)
    else:
        assert report["n_triangles"] == obj.n_triangles


@pytest.mark.parametrize("command", ["tessellate", "info", "fit"])
def test_help_names_the_samples(command, capsys):
    assert main([command, "--help"]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "or the name of an embedded sample (`trimsurf samples --list`)" in out

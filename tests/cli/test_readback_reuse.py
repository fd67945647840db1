"""``trimsurf tessellate``'s read-back check reuses the in-memory figures only for the very mesh measured.

`cli.tessellate._guarantees_met` reads the written file back; where the file holds exactly the mesh that
`tessellate.measure.measure_result` measured (vertices bit for bit, triangles, face ids), the measured
figures are the file's (`tessellate.measure.figures_of_same_mesh`); anything else is measured afresh.
These tests fail if the equality check is dropped (a file one ulp off, or with a triangle turned over,
would then be reported with the in-memory figures).
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

import trimsurf.quality as quality
import trimsurf.tessellate.measure as measure
from trimsurf.cli import main
from trimsurf.cli.tessellate import _guarantees_met
from trimsurf.io import read_mesh, write_mesh
from trimsurf.model import TriMesh
from trimsurf.samples import build_sample
from trimsurf.tessellate import tessellate_shell


@pytest.fixture(scope="module")
def box():
    shell = build_sample("bspline_box")
    return shell, tessellate_shell(shell)


@pytest.fixture
def calls(monkeypatch):
    """Counts the fresh measurements `_guarantees_met` runs on the file read back."""
    n = {"topology": 0, "flipped": 0, "explained": 0}
    real_topo, real_flip, real_expl = (quality.topology_report, measure.flipped_against_normal,
                                       measure.explained_nonmanifold_edges)

    def topo(*a, **k):
        n["topology"] += 1
        return real_topo(*a, **k)

    def flip(*a, **k):
        n["flipped"] += 1
        return real_flip(*a, **k)

    def expl(*a, **k):
        n["explained"] += 1
        return real_expl(*a, **k)

    monkeypatch.setattr(quality, "topology_report", topo)
    monkeypatch.setattr(measure, "flipped_against_normal", flip)
    monkeypatch.setattr(measure, "explained_nonmanifold_edges", expl)
    return n


def _fresh(back: TriMesh, shell, res) -> tuple[int, int, int]:
    """The figures of `back` measured from scratch, as the read-back check did before the reuse."""
    r = res.report
    return (int(quality.topology_report(back).n_non_manifold_edges),
            measure.flipped_against_normal(back, shell, reversed_faces=r.get("faces_flipped", ())),
            int(measure.explained_nonmanifold_edges(back, res.face_meshes, res.tolerance).sum()))


def _check(tmp_path, shell, res, mesh: TriMesh, name: str = "m.ply"):
    """Write `mesh` where the command wrote res.mesh and run the read-back check on it; a copy of the report."""
    target = tmp_path / name
    write_mesh(mesh, target)
    res = dataclasses.replace(res, report=dict(res.report))
    met = _guarantees_met(tmp_path / "box.step", target, res, shell)
    return met, res.report, read_mesh(target)


def test_same_file_reuses_the_measured_figures(box, calls, tmp_path):
    shell, res = box
    met, r, back = _check(tmp_path, shell, res, res.mesh)
    assert calls == {"topology": 0, "flipped": 0, "explained": 0}
    assert met is True
    got = (r["nonmanifold_edges"], r["flipped"], r["nonmanifold_edges_explained"])
    assert got == (res.report["nonmanifold_edges"], res.report["flipped"], res.report["nonmanifold_edges_explained"])
    assert got == _fresh(back, shell, res)        # the figures of the file itself


def test_one_ulp_off_in_one_vertex_is_measured_afresh(box, calls, tmp_path):
    shell, res = box
    v = res.mesh.vertices.copy()
    v[7, 1] = np.nextafter(v[7, 1], np.inf)
    met, r, back = _check(tmp_path, shell, res, dataclasses.replace(res.mesh, vertices=v))
    assert back.vertices[7, 1] == v[7, 1]          # PLY keeps float64: the file does hold the changed bit
    assert calls == {"topology": 1, "flipped": 1, "explained": 1}
    assert (r["nonmanifold_edges"], r["flipped"], r["nonmanifold_edges_explained"]) == _fresh(back, shell, res)


def test_a_turned_vertex_changes_the_figure(box, tmp_path):
    """A file whose vertex is pushed through its face, turning its triangles over: the measured figure is
    the file's (flipped > 0, guarantee not met), not the in-memory 0."""
    shell, res = box
    m = res.mesh
    assert res.report["flipped"] == 0
    # an interior vertex of a face (all its triangles in one face), moved against the face normal far
    # beyond its triangles' size
    star = [np.flatnonzero((m.triangles == i).any(axis=1)) for i in range(m.n_vertices)]
    i = next(i for i in range(m.n_vertices) if len(star[i]) >= 4 and len(np.unique(m.face_id[star[i]])) == 1)
    n = m.triangle_normals()[star[i]].sum(axis=0)
    v = m.vertices.copy()
    v[i] -= 10.0 * m.diagonal() * n / np.linalg.norm(n)
    met, r, back = _check(tmp_path, shell, res, dataclasses.replace(m, vertices=v))
    assert r["flipped"] == _fresh(back, shell, res)[1] >= 1
    assert met is False


def test_a_face_id_off_is_measured_afresh(box, calls, tmp_path):
    shell, res = box
    fid = res.mesh.face_id.copy()
    fid[0] = (fid[0] + 1) % (fid.max() + 1)
    met, r, back = _check(tmp_path, shell, res, dataclasses.replace(res.mesh, face_id=fid))
    # vertices and triangles are those measured: the non-manifold count is the measured one; the flips not
    assert calls == {"topology": 0, "flipped": 1, "explained": 1}
    assert (r["nonmanifold_edges"], r["flipped"], r["nonmanifold_edges_explained"]) == _fresh(back, shell, res)


def test_a_mesh_not_measured_is_measured_afresh(box, calls, tmp_path):
    """The figures belong to the mesh object measured: an equal copy that was never measured gets none."""
    shell, res = box
    copy = TriMesh(res.mesh.vertices.copy(), res.mesh.triangles.copy(), face_id=res.mesh.face_id.copy())
    target = tmp_path / "c.ply"
    write_mesh(copy, target)
    res2 = dataclasses.replace(res, mesh=copy, report=dict(res.report))
    assert _guarantees_met(tmp_path / "box.step", target, res2, shell) is True
    assert calls == {"topology": 1, "flipped": 1, "explained": 1}


def test_figures_of_same_mesh_compares_bits_and_what_was_measured(box):
    shell, res = box
    m, r = res.mesh, res.report
    kw = dict(reversed_faces=r.get("faces_flipped", ()), face_meshes=res.face_meshes, tolerance=res.tolerance)
    assert set(measure.figures_of_same_mesh(m, m, shell, **kw)) == {"nonmanifold_edges", "flipped",
                                                                   "nonmanifold_edges_explained"}
    v = m.vertices.copy()
    k = np.flatnonzero(v.ravel() != 0)[0]
    v.ravel()[k] = -v.ravel()[k] if v.ravel()[k] == 0 else np.nextafter(v.ravel()[k], 0)
    assert measure.figures_of_same_mesh(dataclasses.replace(m, vertices=v), m, shell, **kw) == {}
    zero = np.array([[0.0, 1.0, 2.0]])                          # -0.0 == 0.0 as numbers, not as bits
    assert np.array_equal(zero, -zero * [[1, -1, -1]]) and not measure._same_bits(zero, -zero * [[1, -1, -1]])
    t = m.triangles.copy()
    t[[0, 1]] = t[[1, 0]]
    assert measure.figures_of_same_mesh(dataclasses.replace(m, triangles=t), m, shell, **kw) == {}
    only_topology = {"nonmanifold_edges"}
    assert set(measure.figures_of_same_mesh(dataclasses.replace(m, face_id=None), m, shell, **kw)) == only_topology
    assert set(measure.figures_of_same_mesh(m, m, build_sample("bspline_box"), **kw)) == only_topology
    assert set(measure.figures_of_same_mesh(m, m, shell, **(kw | {"tolerance": 2 * res.tolerance}))) == only_topology
    assert set(measure.figures_of_same_mesh(m, m, shell, **(kw | {"reversed_faces": (0,)}))) == only_topology
    assert set(measure.figures_of_same_mesh(m, m, shell, **(kw | {"face_meshes": tuple(res.face_meshes)[::-1]}))) \
        == only_topology


def test_changed_in_place_after_measuring_is_measured_afresh(calls, tmp_path):
    """The record holds copies of the arrays measured: a mesh changed in place since (its read-only flag
    taken off) is not that mesh."""
    shell = build_sample("bspline_box")
    res = tessellate_shell(shell)
    v = res.mesh.vertices
    v.flags.writeable = True
    v[3, 0] += 1e-3
    target = tmp_path / "x.ply"
    write_mesh(res.mesh, target)
    before = dict(calls)                          # the in-memory measurement's own calls
    _guarantees_met(tmp_path / "box.step", target, res, shell)
    assert {k: calls[k] - before[k] for k in calls} == {"topology": 1, "flipped": 1, "explained": 1}


def test_command_reuses_on_ply_and_reports_the_file_figures(monkeypatch, calls, tmp_path):
    """The whole command, PLY: no fresh measurement of the file read back, and the report's figures are
    those of the file measured from scratch."""
    shell = build_sample("bspline_box")
    monkeypatch.setattr("trimsurf.io.read_shell", lambda path: shell)
    fake = tmp_path / "box.step"
    fake.write_text("not read")
    out, rep = tmp_path / "box.ply", tmp_path / "r.json"
    seen = []
    real = measure.measure_result

    def keep(result, sh):
        seen.append(result)
        return real(result, sh)

    monkeypatch.setattr(measure, "measure_result", keep)
    assert main(["tessellate", str(fake), "-o", str(out), "--report", str(rep)]) == 0
    # the in-memory measurement's own flip test ran (with the deviation's centroid feet); nothing else
    assert calls["topology"] == 0 and calls["explained"] == 1 and calls["flipped"] == 1
    entry = json.loads(rep.read_text())["inputs"][0]
    (res,) = seen
    got = (entry["nonmanifold_edges"], entry["flipped"], entry["nonmanifold_edges_explained"])
    assert got == _fresh(read_mesh(out), shell, res)
    assert entry["guarantees_met"] is True


def test_gc_frozen_during_the_work_and_handed_back(monkeypatch, tmp_path):
    """`cli.tessellate._frozen_gc`: the objects alive after the first read are out of the full collections
    while the command works, and handed back to the collector when it returns."""
    import gc

    import trimsurf.tessellate as tess

    shell = build_sample("bspline_box")
    monkeypatch.setattr("trimsurf.io.read_shell", lambda path: shell)
    real, frozen = tess.tessellate_shell, []

    def spy(*a, **k):
        frozen.append(gc.get_freeze_count())
        return real(*a, **k)

    monkeypatch.setattr(tess, "tessellate_shell", spy)
    fake = tmp_path / "box.step"
    fake.write_text("not read")
    assert gc.get_freeze_count() == 0
    assert main(["tessellate", str(fake), "-o", str(tmp_path / "b.ply")]) == 0
    assert frozen and frozen[0] > 1000
    assert gc.get_freeze_count() == 0

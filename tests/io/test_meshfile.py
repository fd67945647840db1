"""Mesh file I/O through trimesh: round trips with stated tolerances, real meshes, bad files."""

from __future__ import annotations

import logging
import re
import struct

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose, assert_array_equal

import trimsurf.io as tio
from trimsurf.errors import DegenerateError, FileFormatError, MeshError, MeshReadError, TrimsurfWarning
from trimsurf.io import _meshfile
from trimsurf.model import TriMesh
from trimsurf.quality import topology_report

F32 = 2.0 ** -24  # float32 rounding: relative error of a normal float64 -> float32 conversion


def _mesh(scale: float = 1e3, seed: int = 0, uv: bool = True, face_id: bool = False) -> TriMesh:
    """A strip of 2 * 20 triangles on 42 vertices (all used), noisy coordinates of magnitude ~scale."""
    rng = np.random.default_rng(seed)
    n = 21
    x = np.repeat(np.arange(n), 2).astype(float)
    y = np.tile([0.0, 1.0], n)
    v = np.column_stack([x, y, rng.normal(size=2 * n)]) * scale + rng.normal(size=(2 * n, 3)) * scale * 0.1
    k = np.arange(n - 1) * 2
    tris = np.vstack([np.column_stack([k, k + 2, k + 1]), np.column_stack([k + 1, k + 2, k + 3])])
    return TriMesh(v, tris, uv=rng.random((2 * n, 2)) if uv else None,
                   face_id=rng.integers(0, 5, len(tris)) if face_id else None)


# -- round trips --------------------------------------------------------------------

def test_ply_round_trip_is_exact(tmp_path):
    m = _mesh(face_id=True)
    tio.write_mesh(m, tmp_path / "m.ply")
    r = tio.read_mesh(tmp_path / "m.ply")
    assert_array_equal(r.vertices, m.vertices)   # float64 binary: bit-exact
    assert_array_equal(r.triangles, m.triangles)
    assert_array_equal(r.uv, m.uv)
    assert_array_equal(r.face_id, m.face_id)


@pytest.mark.parametrize("suffix", [".obj", ".off"])
@pytest.mark.parametrize("scale", [1e-4, 1.0, 1e5])
def test_text_round_trip_keeps_17_digits_of_the_largest_coordinate(tmp_path, suffix, scale):
    m = _mesh(scale=scale)
    tio.write_mesh(m, tmp_path / f"m{suffix}")
    r = tio.read_mesh(tmp_path / f"m{suffix}")
    big = np.abs(m.vertices).max()
    e = np.floor(np.log10(big))
    # fixed-point text with D = 17 - e decimals: half a unit of the last decimal, plus half an ulp when
    # the decimal is parsed back
    assert_allclose(r.vertices, m.vertices, rtol=0, atol=0.5 * 10 ** (e - 17) + 2.0 ** -53 * big)
    assert_array_equal(r.triangles, m.triangles)
    if suffix == ".obj":
        # uv in [0, 1] share D >= 17 decimals: same bound with e = 0
        assert_allclose(r.uv, m.uv, rtol=0, atol=0.5e-17 + 2.0 ** -53)
    else:
        assert r.uv is None


def test_stl_round_trip_float32_and_merges_duplicates(tmp_path):
    m = _mesh(uv=False)
    tio.write_mesh(m, tmp_path / "m.stl")
    r = tio.read_mesh(tmp_path / "m.stl")
    assert r.n_vertices == m.n_vertices          # every corner of the soup merged back
    assert_array_equal(np.abs(r.vertices[r.triangles] - m.vertices[m.triangles])
                       <= F32 * np.abs(m.vertices[m.triangles]), True)
    # same connectivity up to renumbering: the welded mesh is the same surface
    assert topology_report(r).n_boundary_loops == topology_report(m).n_boundary_loops == 1
    assert r.is_consistently_oriented()


@pytest.mark.parametrize("suffix", [".glb", ".gltf"])
def test_gltf_round_trip_float32(tmp_path, suffix):
    m = _mesh()
    tio.write_mesh(m, tmp_path / f"m{suffix}")
    assert [p.name for p in tmp_path.iterdir()] == [f"m{suffix}"]  # buffers embedded, no side files
    r = tio.read_mesh(tmp_path / f"m{suffix}")
    assert_array_equal(r.triangles, m.triangles)
    assert_array_equal(np.abs(r.vertices - m.vertices) <= F32 * np.abs(m.vertices), True)
    # uv stored as float32 with v flipped (1 - v): error <= 2 float32 ulps of 1
    assert_allclose(r.uv, m.uv, rtol=0, atol=2.5e-7)


@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(exponent=st.integers(-6, 8), seed=st.integers(0, 2 ** 16))
def test_ply_and_obj_round_trip_any_scale(tmp_path, exponent, seed):
    m = _mesh(scale=10.0 ** exponent, seed=seed)
    for suffix in (".ply", ".obj"):
        tio.write_mesh(m, tmp_path / f"h{suffix}")
        r = tio.read_mesh(tmp_path / f"h{suffix}")
        tol = 0.0 if suffix == ".ply" else 5e-16 * np.abs(m.vertices).max()  # see the text round-trip test
        assert np.abs(r.vertices - m.vertices).max() <= tol


# -- reading features ----------------------------------------------------------------

def test_obj_polygons_triangulated_and_vertex_order_kept(tmp_path):
    p = tmp_path / "poly.obj"
    p.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 2 2\nv 9 9 9\nf 1 2 3 4\nf 2 5 3\n")
    m = tio.read_mesh(p)
    assert m.n_triangles == 3
    # the unused vertex 6 is kept in place (trimesh drops it unless asked to keep order)
    assert_array_equal(m.vertices[:, 0], [0, 1, 1, 0, 2, 9])
    # quad (area 1) plus triangle (1,0,0), (2,2,2), (1,1,0) of area |(-2, 0, 1)| / 2
    assert_allclose(m.area(), 1.0 + np.sqrt(5) / 2, rtol=0, atol=1e-15)


def test_obj_uv_kept_when_one_vt_per_v(tmp_path):
    p = tmp_path / "uv.obj"
    p.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.1 0.2\nvt 0.3 0.4\nvt 0.5 0.6\nf 1/1 2/2 3/3\n")
    assert_array_equal(tio.read_mesh(p).uv, [[0.1, 0.2], [0.3, 0.4], [0.5, 0.6]])


def test_obj_uv_seam_drops_uv_with_warning(tmp_path):
    p = tmp_path / "seam.obj"
    p.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvt 0.5 0.5\n"
                 "f 1/5 2/2 3/3\nf 1/1 3/3 4/4\n")
    with pytest.warns(TrimsurfWarning, match="uv dropped"):
        m = tio.read_mesh(p)
    assert m.uv is None
    assert m.n_vertices == 4 and m.triangles.tolist() == [[0, 1, 2], [0, 2, 3]]


def test_several_objects_are_concatenated(tmp_path):
    p = tmp_path / "two.obj"
    p.write_text("o a\nv 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\no b\nv 0 0 1\nv 1 0 1\nv 1 1 1\nf 4 5 6\n")
    m = tio.read_mesh(p)
    assert (m.n_vertices, m.n_triangles) == (6, 2)
    assert_array_equal(m.vertices[:, 2], [0, 0, 0, 1, 1, 1])


def test_glb_scene_with_two_geometries_is_concatenated(tmp_path):
    import trimesh
    a = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], process=False)
    b = trimesh.Trimesh([[0, 0, 5], [1, 0, 5], [0, 1, 5]], [[0, 1, 2]], process=False)
    (tmp_path / "s.glb").write_bytes(trimesh.Scene([a, b]).export(file_type="glb"))
    m = tio.read_mesh(tmp_path / "s.glb")
    assert (m.n_vertices, m.n_triangles) == (6, 2)
    assert sorted(set(m.vertices[:, 2].tolist())) == [0.0, 5.0]


def test_stl_merges_exact_duplicates_only(tmp_path):
    p = tmp_path / "a.stl"
    facet = "facet normal 0 0 1\nouter loop\n{}endloop\nendfacet\n"
    tri = lambda *v: facet.format("".join(f"vertex {x} {y} {z}\n" for x, y, z in v))  # noqa: E731
    p.write_text("solid s\n" + tri((0, 0, 0), (1, 0, 0), (1, 1, 0)) + tri((0, 0, 0), (1, 1, 0), (0, 1, 0))
                 + tri((5, 0, 0), (6, 0, 0), (5, 1e-12, 1)) + "endsolid s\n")
    m = tio.read_mesh(p)
    assert m.n_vertices == 7 and m.triangles[:2].tolist() == [[0, 1, 2], [0, 2, 3]]


def test_off_quads_triangulated(tmp_path):
    p = tmp_path / "q.off"
    p.write_text("OFF\n5 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n2 2 2\n4 0 1 2 3\n3 0 2 4\n")
    m = tio.read_mesh(p)
    assert m.n_triangles == 3 and m.n_vertices == 5
    assert_allclose(m.triangle_areas().sum(), 1.0 + np.linalg.norm(np.cross([1, 1, 0], [2, 2, 2])) / 2,
                    rtol=0, atol=1e-14)


def test_zero_area_triangle_with_distinct_indices_reads(tmp_path):
    p = tmp_path / "z.obj"
    p.write_text("v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 4\n")
    m = tio.read_mesh(p)
    assert m.degenerate_triangles().tolist() == [0]


# -- real meshes ---------------------------------------------------------------------

def _readme_table(readme: str) -> list[dict]:
    rows = [ln for ln in readme.splitlines() if ln.startswith("| ") and not ln.startswith("| file")]
    out = []
    for ln in rows:
        cells = [c.strip() for c in ln.strip("|").split("|")]
        out.append({"file": cells[0], "V": int(cells[3]), "F": int(cells[4]), "loops": int(cells[5]),
                    "chi": int(cells[6]), "genus": int(cells[7])})
    return out


def test_real_meshes_match_readme_table(shared_data):
    folder = shared_data / "meshes"
    table = _readme_table((folder / "README.md").read_text())
    files = sorted(p.name for p in folder.iterdir() if p.suffix in (".obj", ".off"))
    assert sorted(r["file"] for r in table) == files and len(files) == 12
    for row in table:
        m = tio.read_mesh(folder / row["file"])
        got = (m.n_vertices, m.n_triangles, len(m.boundary_loops()), m.euler_characteristic())
        assert got == (row["V"], row["F"], row["loops"], row["chi"]), row["file"]
        assert not len(m.non_manifold_edges()) and not len(m.non_manifold_vertices()), row["file"]


def test_real_mesh_round_trips_through_every_format(shared_data, tmp_path):
    m = tio.read_mesh(shared_data / "meshes" / "nefertiti.off")
    for suffix in _meshfile.FORMATS:
        tio.write_mesh(m, tmp_path / f"n{suffix}")
        r = tio.read_mesh(tmp_path / f"n{suffix}")
        assert (r.n_vertices, r.n_triangles, r.euler_characteristic()) == (299, 562, 1), suffix


# -- bad files -----------------------------------------------------------------------

BAD = {
    "garbage.obj": b"garbage \x00\x01 blah\n",
    "garbage.off": b"hello world\n",
    "garbage.stl": b"junk junk",
    "garbage.glb": b"junk",
    "garbage.ply": b"ply\nnonsense\n",
    "truncated.off": b"OFF\n3 1 0\n0 0 0\n1 0 0\n",
    "truncated.ply": (b"ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                      b"property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                      b"0 0 0\n1 0 0\n"),
    "truncated.stl": b"\0" * 80 + struct.pack("<I", 5) + b"\0" * 60,
    "truncated.gltf": b'{"asset":',
    "nofaces.obj": b"v 0 0 0\nv 1 0 0\nv 1 1 0\n",
    "pointcloud.ply": (b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                       b"property float z\nend_header\n0 0 0\n1 0 0\n1 1 0\n"),
    "badindex.obj": b"v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 7\n",
}


@pytest.mark.parametrize("name", sorted(BAD))
def test_bad_file_raises_one_line_naming_the_file(tmp_path, name, capfd):
    p = tmp_path / name
    p.write_bytes(BAD[name])
    with pytest.raises(MeshReadError, match=re.escape(str(p))) as info:
        _meshfile.read(p)
    assert "\n" not in str(info.value)
    assert info.value.__cause__ is None or isinstance(info.value.__cause__, Exception)
    out, err = capfd.readouterr()
    assert out == "" and err == ""  # no log noise from trimesh


def test_trimesh_logger_level_restored(tmp_path):
    p = tmp_path / "g.off"
    p.write_bytes(b"hello\n")
    level = logging.getLogger("trimesh").level
    with pytest.raises(MeshReadError):
        _meshfile.read(p)
    assert logging.getLogger("trimesh").level == level


@pytest.mark.parametrize("name, text, error, what", [
    ("nan.obj", "v 0 0 0\nv 1 0 nan\nv 1 1 0\nf 1 2 3\n", MeshError, "non-finite"),
    ("nan.off", "OFF\n3 1 0\n0 0 0\n1 nan 0\n1 1 0\n3 0 1 2\n", MeshError, "non-finite"),
    ("range.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n1 1 0\n3 0 1 5\n", MeshError, "out of range"),
    ("repeat.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 2\n", DegenerateError, "repeats a vertex"),
    ("repeat.stl", "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 1 0 0\n"
                   "endloop\nendfacet\nendsolid s\n", DegenerateError, "repeats a vertex"),
])
def test_bad_content_raises_mesh_error_naming_file(tmp_path, name, text, error, what):
    p = tmp_path / name
    p.write_text(text)
    with pytest.raises(error, match=re.escape(str(p)) + ".*" + what):
        _meshfile.read(p)


def test_nan_in_binary_stl(tmp_path):
    tris = np.array([[[0, 0, 0], [1, 0, 0], [np.nan, 1, 0]]], dtype="<f4")
    data = b"\0" * 80 + struct.pack("<I", 1) + (np.zeros(3, "<f4").tobytes() + tris.tobytes() + b"\0\0")
    p = tmp_path / "nan.stl"
    p.write_bytes(data)
    with pytest.raises(MeshError, match="nan.stl.*non-finite"):
        _meshfile.read(p)


def test_empty_missing_and_unknown_files(tmp_path):
    (tmp_path / "e.obj").write_bytes(b"")
    with pytest.raises(MeshReadError, match="e.obj: file is empty"):
        _meshfile.read(tmp_path / "e.obj")
    with pytest.raises(FileFormatError, match="e.obj: file is empty"):
        tio.read_mesh(tmp_path / "e.obj")
    with pytest.raises(MeshReadError, match="no such file"):
        _meshfile.read(tmp_path / "missing.ply")
    with pytest.raises(MeshReadError, match="unknown mesh file suffix '.xyz'"):
        _meshfile.read(tmp_path / "a.xyz")


# -- writing -------------------------------------------------------------------------

def test_write_rejects_bad_input_and_leaves_no_file(tmp_path):
    with pytest.raises(MeshError, match="expected a TriMesh"):
        _meshfile.write("not a mesh", tmp_path / "a.obj")
    with pytest.raises(MeshError, match="no triangles"):
        _meshfile.write(TriMesh(np.zeros((3, 3)), np.zeros((0, 3))), tmp_path / "b.ply")
    with pytest.raises(MeshReadError, match="unknown mesh file suffix"):
        _meshfile.write(_mesh(), tmp_path / "c.xyz")
    assert list(tmp_path.iterdir()) == []


def test_failed_encoding_keeps_existing_file(tmp_path, monkeypatch):
    target = tmp_path / "keep.obj"
    target.write_text("old")

    def boom(mesh, suffix):
        raise RuntimeError("encoder exploded")

    monkeypatch.setattr(_meshfile, "_encode", boom)
    with pytest.raises(MeshError, match="keep.obj: cannot encode OBJ: encoder exploded"):
        _meshfile.write(_mesh(), target)
    assert target.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["keep.obj"]


def test_write_does_not_mutate_mesh(tmp_path):
    m = _mesh(face_id=True)
    before = (m.vertices.copy(), m.triangles.copy(), m.uv.copy())
    for suffix in _meshfile.FORMATS:
        if suffix in (".bdf", ".nas"):  # Nastran's 16-column fields move these coordinates: it warns
            with pytest.warns(TrimsurfWarning, match="11-12 significant digits"):
                _meshfile.write(m, tmp_path / f"w{suffix}")
            continue
        _meshfile.write(m, tmp_path / f"w{suffix}")
    assert_array_equal(m.vertices, before[0])
    assert_array_equal(m.triangles, before[1])
    assert_array_equal(m.uv, before[2])

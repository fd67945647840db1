"""CAE mesh formats through meshio: VTK, VTU, Gmsh MSH, Abaqus INP, Nastran BDF/NAS.

Round trips keep vertices (float64 bits, order) and triangles exactly;
Nastran's 16-column fields keep 11-12 significant digits (exact for
coordinates that have no more, warned otherwise). Files are also read back
by an independent reader where one is installed (VTK through pyvista, MSH
through the gmsh API) to show they are what the format says.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_array_equal

import trimsurf.io as tio
from trimsurf.cli import main
from trimsurf.errors import FileFormatError, MeshError, MeshReadError, TrimsurfWarning
from trimsurf.model import TriMesh

EXACT = (".vtk", ".vtu", ".msh", ".inp")
NASTRAN = (".bdf", ".nas")


def _mesh(seed: int = 0, scale: float = 1e3) -> TriMesh:
    """Random float64 coordinates (all 17 digits significant, both signs, tiny values), uv, face_id."""
    rng = np.random.default_rng(seed)
    n = 40
    v = rng.normal(size=(n, 3)) * scale
    v[0] = [1e-11, -3.2e-13, 0.0]          # exponents of two digits and a zero
    tris = np.array([[i, (i + 1) % n, (i + 7) % n] for i in range(n)], dtype=np.int64)
    return TriMesh(v, tris, uv=rng.random((n, 2)), face_id=rng.integers(0, 6, n))


@pytest.mark.parametrize("suffix", EXACT)
def test_round_trip_is_exact(tmp_path, suffix):
    m = _mesh()
    path = tmp_path / f"m{suffix}"
    tio.write_mesh(m, path)
    r = tio.read_mesh(path)
    assert r.vertices.dtype == np.float64 and r.vertices.dtype.isnative and r.triangles.dtype == np.int64
    assert_array_equal(r.vertices, m.vertices)       # bit for bit, same order
    assert_array_equal(r.triangles, m.triangles)
    if suffix in (".vtk", ".vtu"):                   # the formats that keep uv and face_id
        assert_array_equal(r.uv, m.uv)
        assert_array_equal(r.face_id, m.face_id)


@pytest.mark.parametrize("suffix", NASTRAN)
def test_nastran_keeps_11_significant_digits_and_says_so(tmp_path, suffix):
    m = _mesh()
    path = tmp_path / f"m{suffix}"
    with pytest.warns(TrimsurfWarning, match="11-12 significant digits: coordinates moved by up to"):
        tio.write_mesh(m, path)
    r = tio.read_mesh(path)
    assert_array_equal(r.triangles, m.triangles)
    assert_array_equal(r.face_id, m.face_id)         # PSHELL ids face_id + 1
    # 16 columns: '-1.2345678901E+3' keeps 11 significant digits -> relative error <= 0.5e-10
    err = np.abs(r.vertices - m.vertices)
    assert np.all(err <= 5e-11 * np.abs(m.vertices)), float((err / np.abs(m.vertices).clip(1e-300)).max())
    assert err.max() > 0                              # the random coordinates did move (the warning is true)
    assert "GRID*" in path.read_text() and "CTRIA3" in path.read_text()


@pytest.mark.parametrize("suffix", NASTRAN)
def test_nastran_is_exact_for_coordinates_with_few_digits(tmp_path, suffix, recwarn):
    rng = np.random.default_rng(3)
    m = _mesh()
    m = TriMesh(np.round(rng.normal(size=m.vertices.shape) * 1e3, 6), m.triangles)  # micrometres on metres
    tio.write_mesh(m, tmp_path / f"m{suffix}")
    assert not [w for w in recwarn if issubclass(w.category, TrimsurfWarning)]
    r = tio.read_mesh(tmp_path / f"m{suffix}")
    assert_array_equal(r.vertices, m.vertices)
    assert_array_equal(r.triangles, m.triangles)


def test_abaqus_writes_shell_elements(tmp_path):
    tio.write_mesh(_mesh(), tmp_path / "m.inp")
    text = (tmp_path / "m.inp").read_text()
    assert "*ELEMENT, TYPE=S3\n" in text and "R3D3" not in text


@pytest.mark.parametrize("suffix", (".vtk", ".vtu"))
def test_vtk_files_read_by_pyvista(tmp_path, suffix):
    import pyvista

    m = _mesh()
    tio.write_mesh(m, tmp_path / f"m{suffix}")
    pv = pyvista.read(tmp_path / f"m{suffix}")
    assert_array_equal(np.asarray(pv.points, dtype=np.float64), m.vertices)
    cells = pv.cells_dict[int(pyvista.CellType.TRIANGLE)]
    assert_array_equal(cells, m.triangles)
    assert_array_equal(pv.cell_data["face_id"], m.face_id)


def test_msh_read_by_gmsh(tmp_path):
    gmsh = pytest.importorskip("gmsh")  # the bench extra
    m = _mesh()
    tio.write_mesh(m, tmp_path / "m.msh")
    gmsh.initialize(["", "-v", "0"])
    try:
        gmsh.open(str(tmp_path / "m.msh"))
        tags, coords, _ = gmsh.model.mesh.getNodes()
        types, _, nodes = gmsh.model.mesh.getElements(2)
    finally:
        gmsh.finalize()
    order = np.argsort(tags)
    assert_array_equal(coords.reshape(-1, 3)[order], m.vertices)
    assert list(types) == [2]                                  # 3-node triangles
    assert_array_equal(np.asarray(nodes[0]).reshape(-1, 3) - 1, m.triangles)


def test_quads_split_other_cells_dropped(tmp_path):
    import meshio

    pts = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1]], dtype=float)
    mm = meshio.Mesh(pts, [("line", np.array([[0, 1]])), ("quad", np.array([[0, 1, 2, 3]])),
                           ("triangle", np.array([[0, 1, 4]])), ("tetra", np.array([[0, 1, 2, 4]]))])
    meshio.write(tmp_path / "q.vtu", mm)
    with pytest.warns(TrimsurfWarning, match="dropped: 1 tetra"):
        r = tio.read_mesh(tmp_path / "q.vtu")
    assert r.triangles.tolist() == [[0, 1, 2], [0, 2, 3], [0, 1, 4]]
    assert r.n_vertices == 5


@pytest.mark.parametrize("suffix", EXACT + NASTRAN)
def test_bad_files_one_line_error(tmp_path, suffix):
    bad = tmp_path / f"bad{suffix}"
    bad.write_bytes(b"this is not a mesh \x00\x01\n" * 3)
    with pytest.raises(MeshReadError) as info:
        tio.read_mesh(bad)
    assert str(bad) in str(info.value) and "\n" not in str(info.value)
    empty = tmp_path / f"empty{suffix}"
    empty.write_bytes(b"")
    with pytest.raises(FileFormatError, match="empty"):
        tio.read_mesh(empty)


def test_no_triangles_and_failed_write_leave_nothing(tmp_path):
    import meshio

    meshio.write(tmp_path / "lines.vtu", meshio.Mesh(np.eye(3), [("line", np.array([[0, 1], [1, 2]]))]))
    with pytest.raises(MeshReadError, match="no triangles"):
        tio.read_mesh(tmp_path / "lines.vtu")
    with pytest.raises(MeshError, match="no triangles"):
        tio.write_mesh(TriMesh(np.eye(3), np.zeros((0, 3), dtype=np.int64)), tmp_path / "out.msh")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["lines.vtu"]


@pytest.mark.parametrize("suffix", (".vtu", ".msh", ".inp", ".bdf"))
def test_cli_chooses_the_format_by_suffix(tmp_path, suffix, capsys):
    from trimsurf.samples import build_sample

    step = tmp_path / "box.step"
    tio.write_shell(build_sample("bspline_box"), step)
    out = tmp_path / f"box{suffix}"
    assert main(["tessellate", str(step), "-o", str(out)]) == 0
    r = tio.read_mesh(out)
    assert r.is_watertight() and r.n_triangles > 100
    capsys.readouterr()
    assert main(["info", str(out), "--json"]) == 0
    assert '"n_triangles": %d' % r.n_triangles in capsys.readouterr().out

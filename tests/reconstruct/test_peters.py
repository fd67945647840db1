"""Peters' single-quintic fill, G1 errors of every fill, and the curvature-jump measurement.

The MNN paper (section 4): "Peters' method yields one quintic Bézier patch per facet with,
in general, some error in the G1 surface-surface match"; it is G1 where the vertex
enclosure problem (VEP) is solvable (Fig. 5); the split fills and the G2 network's fills
are G1 (sections 4 and 6). Every figure is sampled along the patch edges.
"""

from __future__ import annotations

import numpy as np
import pytest

from trimsurf import io
from trimsurf.geom import bezier_triangle_points, triangle_indices
from trimsurf.model import TriMesh
from trimsurf.reconstruct import (PatchSet, build_network, fill_peters_quintic, fill_single_quintic, g1_continuity,
                                  reconstruct_mesh, vertex_interpolation_error)
from trimsurf.reconstruct.fill import FacetPatches
from trimsurf.samples import octahedron

from .conftest import icosphere

G1_TOL_RAD = 1e-8
FILLS = [("g1", "split"), ("shirman-sequin", "split"), ("g1", "peters"), ("g1", "single"), ("g2", "split"),
         ("g2", "single")]
EXACT = {("g1", "split"), ("shirman-sequin", "split"), ("g2", "split"), ("g2", "single")}


@pytest.fixture(scope="module")
def reports(shared_data):
    meshes = {"octahedron": octahedron(), "nefertiti": io.read_mesh(shared_data / "meshes" / "nefertiti.off")}
    return {(name, net, fill): reconstruct_mesh(m, network=net, fill=fill).report
            for name, m in meshes.items() for net, fill in FILLS}


@pytest.mark.parametrize("name", ["octahedron", "nefertiti"])
def test_g1_error_of_every_fill(reports, name):
    """The split and G2 fills are G1; Peters' is not in general but much closer than the
    Chiyokura-Kimura quintic with averaged twists (the fill that used to carry the name)."""
    r = {(net, fill): reports[(name, net, fill)] for net, fill in FILLS}
    for key in EXACT:
        assert np.radians(r[key]["g1_error_max_deg"]) < G1_TOL_RAD, key
    peters, ck = r[("g1", "peters")]["g1_error_max_deg"], r[("g1", "single")]["g1_error_max_deg"]
    # measured: octahedron 0.81 vs 18.3 degrees, nefertiti 3.67 vs 12.3 degrees
    assert 0.1 < peters < {"octahedron": 1.0, "nefertiti": 4.0}[name]
    assert peters < {"octahedron": 0.1, "nefertiti": 0.4}[name] * ck
    # the shifted octahedron has valence 4 everywhere: the VEP is not solvable at any vertex
    if name == "octahedron":
        assert r[("g1", "peters")]["g1_residual_vertices"] == 6
    for key in FILLS:
        rep = r[key]
        assert rep["g1_sampling"].startswith("sampled: 17 points")
        assert rep["vertex_interpolation_error"] < 1e-9 and rep["g0_gap"] < 1e-9


@pytest.mark.parametrize("mesh", ["octahedron_regular", "icosphere"])
def test_peters_is_g1_where_the_vep_is_solvable(mesh):
    """Regular octahedron (valence 4, symmetric curves) and icosphere (valences 5 and 6): the
    vertex enclosure constraint holds, so Peters' quintics meet G1 (paper, Fig. 5)."""
    m = octahedron(shift_deg=0.0) if mesh == "octahedron_regular" else icosphere(1)
    net = build_network(m, kind="g1")
    # undamped solve: exact to rounding
    fp, info = fill_peters_quintic(net, damping=1e-9)
    ps = PatchSet.from_patches(fp, m.vertices, m.triangles)
    assert np.radians(g1_continuity(ps, n_samples=33)["g1_angle_max_deg"]) < G1_TOL_RAD
    assert info["g1_residual_vertices"] == 0 and info["g1_condition_residual_max"] < 1e-12
    # default (damped) solve: 2.1e-5 degrees measured on the icosphere
    rep = reconstruct_mesh(m, network="g1", fill="peters").report
    assert rep["g1_error_max_deg"] < 1e-4
    assert rep["degree"] == 5 and rep["patches"] == m.n_triangles
    # the fill it starts from is not G1 there
    ck = PatchSet.from_patches(fill_single_quintic(net), m.vertices, m.triangles)
    assert g1_continuity(ck)["g1_angle_max_deg"] > 0.1


def test_peters_keeps_the_shape(shared_data):
    """The weights' solve moves only inner control points, and not wildly: vertices and
    network curves stay, and the curvature jump stays of the order of the other fills'."""
    m = io.read_mesh(shared_data / "meshes" / "hole_sphere1.off")
    net = build_network(m, kind="g1")
    fp, info = fill_peters_quintic(net)
    ref = fill_single_quintic(net)
    ps = PatchSet.from_patches(fp, m.vertices, m.triangles)
    assert vertex_interpolation_error(ps) < 1e-12
    moved = np.abs(fp.control_points - ref.control_points).max(axis=2) > 0
    inner = [i for i, key in enumerate(map(tuple, triangle_indices(5))) if min(key) >= 1]
    assert not moved[:, np.setdiff1d(np.arange(21), inner)].any() and moved[:, inner].any()
    c = g1_continuity(ps, curvature=True)
    split = reconstruct_mesh(m, network="g1", fill="split").report
    assert c["g1_angle_max_deg"] < 0.2 * g1_continuity(PatchSet.from_patches(ref, m.vertices, m.triangles))[
        "g1_angle_max_deg"]                                  # 0.040 vs 0.379 degrees measured
    assert c["curvature_jump_max"] < 2 * split["curvature_jump_max"]      # 0.23 vs 0.37 measured


def test_g1_maxima_are_dense_enough(shared_data):
    """17 samples per edge find the maximum of 257 samples to within 3 %."""
    for m, fill in ((octahedron(), "peters"), (io.read_mesh(shared_data / "meshes" / "nefertiti.off"), "single")):
        rec = reconstruct_mesh(m, network="g1", fill=fill)
        dense = g1_continuity(rec.patches, n_samples=257, curvature=True)
        assert rec.report["g1_angle_max_deg"] <= dense["g1_angle_max_deg"] + 1e-12
        assert rec.report["g1_angle_max_deg"] > 0.97 * dense["g1_angle_max_deg"]
        assert rec.report["curvature_jump_max"] > 0.9 * dense["curvature_jump_max"]


# ----------------------------------------------------------------------------- the curvature-jump measurement


def _poly_patches(corners_xy, f, n=2):
    """Degree-n triangular Bézier patches reproducing the graph z = f(x, y) over 2D triangles."""
    idx = triangle_indices(n)
    bary = idx / n
    B = bezier_triangle_points(np.eye(len(idx)), n, bary)            # (k, N) collocation
    out = []
    for tri in corners_xy:
        xy = bary @ np.asarray(tri, float)
        pts = np.c_[xy, f(xy[:, 0], xy[:, 1])]
        out.append(np.linalg.solve(B, pts))
    return np.array(out)


def _square_patchset(f_lower, f_upper=None):
    """Four triangles over [-1, 1]^2, two below y = 0 (graph of f_lower) and two above (f_upper)."""
    V2 = np.array([[-1, -1], [1, -1], [1, 0], [-1, 0], [1, 1], [-1, 1]], float)
    T = np.array([[0, 1, 2], [0, 2, 3], [3, 2, 4], [3, 4, 5]])
    f_upper = f_upper or f_lower
    cps = [_poly_patches([V2[t]], f_lower if k < 2 else f_upper)[0] for k, t in enumerate(T)]
    V = np.c_[V2, np.zeros(len(V2))]
    V[:, 2] = [f_lower(*v) if v[1] <= 0 else f_upper(*v) for v in V2]
    return PatchSet.from_patches(FacetPatches(2, np.array(cps), np.arange(4), np.full(4, -1)), V, T)


def test_curvature_jump_is_zero_on_one_polynomial_and_exact_on_a_known_jump():
    smooth = _square_patchset(lambda x, y: 0.5 * x * x + 0.3 * x * y + 0.25 * y * y)
    c = g1_continuity(smooth, curvature=True, interior=False)
    assert c["curvature_jump_max"] < 1e-12 and c["mean_curvature_jump_max"] < 1e-12
    assert np.radians(c["g1_angle_max_deg"]) < G1_TOL_RAD
    # z = 0 below y = 0, z = y^2 above: G1 across y = 0, normal curvature across jumps by exactly 2
    # (mean curvature by 1); the diagonal edges inside each half are smooth
    jump = _square_patchset(lambda x, y: 0.0 * x, lambda x, y: y * y)
    c = g1_continuity(jump, curvature=True, interior=False)
    assert np.radians(c["g1_angle_max_deg"]) < G1_TOL_RAD
    assert abs(c["curvature_jump_max"] - 2.0) < 1e-9 and abs(c["mean_curvature_jump_max"] - 1.0) < 1e-9
    # the per-edge figures put it on the shared edge y = 0 only
    assert np.sort(c["edge_curvature_jumps"]).round(9).tolist() == [0.0, 0.0, 2.0]


def test_report_curvature_jumps_are_measured_not_constant(bumpy_sphere):
    """Scaling the mesh by 2 halves the curvature jumps (1/length) and leaves the G1 error;
    the figures differ between fills."""
    seen = set()
    for net, fill in (("g1", "split"), ("g1", "peters"), ("g2", "single")):
        r1 = reconstruct_mesh(bumpy_sphere, network=net, fill=fill).report
        big = TriMesh(2.0 * bumpy_sphere.vertices, bumpy_sphere.triangles)
        r2 = reconstruct_mesh(big, network=net, fill=fill).report
        assert r1["curvature_jump_max"] > 0
        assert r2["curvature_jump_max"] == pytest.approx(0.5 * r1["curvature_jump_max"], rel=1e-6)
        assert r2["mean_curvature_jump_max"] == pytest.approx(0.5 * r1["mean_curvature_jump_max"], rel=1e-6)
        assert r2["g1_error_max_deg"] == pytest.approx(r1["g1_error_max_deg"], rel=1e-6, abs=1e-9)
        seen.add(round(r1["curvature_jump_max"], 6))
    assert len(seen) == 3


def test_reported_g1_error_agrees_with_an_independent_evaluation():
    """The report's G1 figure, recomputed from the patches by generic derivative evaluation
    (not the control-row shortcut) at the same edge parameters."""
    from trimsurf.geom import bezier_triangle_derivatives

    m = octahedron()
    rec = reconstruct_mesh(m, network="g1", fill="peters")
    cp, T = rec.patches.control_points, m.triangles
    t = np.linspace(0, 1, 19)[1:-1]
    worst = 0.0
    for f1 in range(len(T)):
        for k1 in range(3):
            a, b = T[f1, k1], T[f1, (k1 + 1) % 3]
            f2, k2 = next((f, k) for f in range(len(T)) for k in range(3)
                          if T[f, k] == b and T[f, (k + 1) % 3] == a)
            normals = []
            for f, k, tt in ((f1, k1, t), (f2, k2, t[::-1])):
                bary = np.zeros((len(tt), 3))
                bary[:, k], bary[:, (k + 1) % 3] = 1 - tt, tt
                D = bezier_triangle_derivatives(cp[f], 5, bary)
                nrm = np.cross(D[1, 0], D[0, 1])
                normals.append(nrm / np.linalg.norm(nrm, axis=1, keepdims=True))
            cos = np.clip(np.einsum("ij,ij->i", *normals), -1, 1)
            worst = max(worst, float(np.degrees(np.arccos(cos)).max()))
    assert worst == pytest.approx(rec.report["g1_error_max_deg"], rel=1e-6)


def test_peters_patches_are_regular(bumpy_sphere):
    """The least-squares moves of the inner control points do not fold a patch: the Jacobian
    keeps the facet's orientation at every sample (10 per side), and no curve folds."""
    from trimsurf.geom import bezier_triangle_derivatives

    rec = reconstruct_mesh(bumpy_sphere, network="g1", fill="peters")
    g = 10
    bary = np.array([(a, b, g - a - b) for a in range(g + 1) for b in range(g + 1 - a)], float) / g
    D = bezier_triangle_derivatives(rec.patches.control_points, 5, bary)
    V, T = bumpy_sphere.vertices, bumpy_sphere.triangles
    nf = np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]])
    assert np.einsum("pki,pi->pk", np.cross(D[1, 0], D[0, 1]), nf).min() > 0
    assert rec.report["folded_edges"] == 0 and rec.report["weight_sign_changes"] == 0

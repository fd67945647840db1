"""Issue 13, timing: the strip's deviation check skips triangles an a-priori bound proves fine, and step 5
reuses the refinement's last Whitney average and foot points; neither may change the output."""

from __future__ import annotations

import numpy as np
import pytest

import trimsurf.io as tio
from trimsurf.join import _accuracy, _patch, join_shell
from trimsurf.join._patch import _second_derivative_bound
from trimsurf.samples.folding_pair import folding_pair, folding_pair_meshes


def _hessian_quadratic(surface, uv, h, scale):
    """|D^2 F(w)[h, h]| in w = uv * scale at the points uv, directions h (unit, in w)."""
    d = surface.derivatives(uv, 2)
    a, b = h[:, 0] / scale[0], h[:, 1] / scale[1]
    q = d[2, 0] * (a * a)[:, None] + 2 * d[1, 1] * (a * b)[:, None] + d[0, 2] * (b * b)[:, None]
    return np.linalg.norm(q, axis=1)


@pytest.mark.parametrize("name", ["gmsh__t20_data.step", "occt__screw.step", "gmsh__U_Joint_2.stp"])
def test_second_derivative_bound_holds(shared_data, name):
    # the control-net bound is above |D^2 F[h, h]| at 4000 random (u, v, h) on every polynomial face
    shell = tio.read_shell(shared_data / "cad" / name)
    rng = np.random.default_rng(3)
    n_poly = 0
    for face in shell.faces:
        s = face.surface
        scale = np.exp(rng.uniform(-2, 2, 2))
        m = _second_derivative_bound(s, scale)
        if s.is_rational:
            assert m == np.inf
            continue
        n_poly += 1
        (u0, u1), (v0, v1) = s.domain
        uv = np.column_stack([rng.uniform(u0, u1, 4000), rng.uniform(v0, v1, 4000)])
        ang = rng.uniform(0, np.pi, 4000)
        h = np.column_stack([np.cos(ang), np.sin(ang)])
        got = _hessian_quadratic(s, uv, h, scale)
        assert got.max() <= m * (1 + 1e-9)
    assert n_poly > 0


def _count_sampling(monkeypatch):
    calls = []
    real = _accuracy.triangle_deviation

    def counting(face, points, uv, triangles, **kw):
        calls.append(len(triangles))
        return real(face, points, uv, triangles, **kw)

    monkeypatch.setattr(_accuracy, "triangle_deviation", counting)
    return calls


def test_bound_skips_and_changes_nothing(shared_data, monkeypatch):
    # t20 at the CLI's deflection: 2 of its 21 faces need refinement passes. The a-priori bound spares the
    # sampling of part of the strip; the joined mesh is the same to the bit as with every triangle sampled
    shell = tio.read_shell(shared_data / "cad" / "gmsh__t20_data.step")
    d = 1e-3 * shell.diagonal()
    meshes = tio.occ_mesh_faces(shell, linear_deflection=d)
    calls = _count_sampling(monkeypatch)
    fast = join_shell(shell, meshes, deflection=d, measure=False)
    sampled_fast = sum(calls)
    calls.clear()
    monkeypatch.setattr(_patch, "_second_derivative_bound", lambda surface, scale: float("inf"))
    slow = join_shell(shell, meshes, deflection=d, measure=False)
    sampled_all = sum(calls)
    assert sampled_fast < sampled_all
    assert np.array_equal(fast.mesh.vertices, slow.mesh.vertices)
    assert np.array_equal(fast.mesh.triangles, slow.mesh.triangles)
    assert [f.refine_passes for f in fast.faces] == [f.refine_passes for f in slow.faces]
    assert sum(f.refine_passes for f in fast.faces) > 0


def test_paper_size_strip_needs_no_sampling(monkeypatch):
    # the folding pair with the benchmark's grids: every strip triangle is proven within the target, so the
    # check costs no surface sampling; and step 5 reuses the refinement's values: the same mesh as a join
    # whose step 5 evaluates everything itself (no refinement at all: deflection inf, same strip here)
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
    try:
        from join_scaling import grid_deviation, grid_meshes, perimeter
    finally:
        sys.path.pop(0)
    shell = folding_pair()
    meshes = grid_meshes(shell, 2100)
    spacing = max(perimeter(f) for f in shell.faces) / 80
    d = grid_deviation(shell, meshes, 2100)
    calls = _count_sampling(monkeypatch)
    res = join_shell(shell, meshes, edge_spacing=spacing, measure=False, deflection=d)
    assert calls == []
    ref = join_shell(shell, meshes, edge_spacing=spacing, measure=False, deflection=float("inf"))
    assert np.array_equal(res.mesh.triangles, ref.mesh.triangles)
    assert np.array_equal(res.mesh.vertices, ref.mesh.vertices)
    # and the sample pair still joins without folding
    res = join_shell(shell, folding_pair_meshes(shell))
    assert res and res.report["flipped_after"] == 0

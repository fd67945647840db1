"""Session 27 (issue 17, meshing speed): the per-face checks folded into compiled passes equal the Python
they replace: `_plane_offset`'s early answer for curved surfaces (`curved_kernel`) and Triangle called
with its own types and switches."""

from __future__ import annotations

import numpy as np
import pytest

from trimsurf.io import read_shell
from trimsurf.model import NurbsSurface
from trimsurf.tessellate import face as face_mod
from trimsurf.tessellate import grid as grid_mod
from trimsurf.tessellate._mesh_kernels import curved_kernel


def _same_plane(a, b) -> bool:
    if a is None or b is None:
        return a is None and b is None
    return a[0] == b[0] and np.array_equal(a[1], b[1]) and a[2] == b[2]


def _kernel_says_curved(s, tol) -> bool:
    w = s.weights
    return bool(curved_kernel(s.control_points, face_mod._NO_W if w is None else w, w is not None,
                              tol is not None, 0.0 if tol is None else float(tol)))


def test_plane_offset_shortcut_on_real_surfaces(shared_data):
    """On every surface of four models, with and without a tolerance: `_plane_offset` equals
    `_plane_offset_numpy`, and where `curved_kernel` answers "curved" the numpy path answers None; the
    kernel settles most curved surfaces."""
    n = {"curved": 0, "settled": 0, "plane": 0}
    for name in ("trimesh__featuretype.STEP", "gmsh__t20_data.step", "occt__screw.step", "gmsh__U_Joint_2.stp"):
        shell = read_shell(shared_data / "cad" / name)
        d = shell.diagonal()
        for f in shell.faces:
            s = f.surface
            assert not s.control_points.flags.writeable      # the model's arrays: the kernel is asked
            for tol in (None, 1e-3 * d, 1e-12 * d):
                want = face_mod._plane_offset_numpy(s, tol)
                assert _same_plane(face_mod._plane_offset(s, tol), want)
                said = _kernel_says_curved(s, tol)
                assert not (said and want is not None)
                n["curved"] += want is None
                n["settled"] += said
                n["plane"] += want is not None
    assert n["plane"] > 100 and n["settled"] > 0.9 * n["curved"], n


def _bumped(height, offset, rational):
    """A 3 x 3 control net on the plane z = offset (x, y in [0, 2], moved by `offset` too) with its middle
    point lifted by `height`: the spread along the normal is height / 2."""
    g = np.linspace(0.0, 2.0, 3)
    cp = np.zeros((3, 3, 3))
    cp[..., 0], cp[..., 1] = np.meshgrid(g, g, indexing="ij")
    cp += offset
    cp[1, 1, 2] += height
    knots = np.array([0, 0, 0, 1, 1, 1.0])
    w = np.array([[1, 0.7, 1], [0.7, 0.5, 0.7], [1, 0.7, 1.0]]) if rational else None
    return NurbsSurface(2, 2, knots, knots, cp, w)


@pytest.mark.parametrize("rational", [False, True])
def test_plane_offset_shortcut_at_its_limit(rational):
    """Control nets whose spread lies just below, at and just above `_plane_offset`'s limit (both kinds of
    limit: 1e-9 of the net's size, 1e-3 of the tolerance), far from the origin too: the same answer as the
    numpy path each time, planes among them, and the kernel settles the clearly curved ones only."""
    size = np.sqrt(8.0)
    n_plane = n_none = n_settled = 0
    for tol in (None, 1e-7 * size):
        limit = 1e-9 * size if tol is None else min(1e-9 * size, 1e-3 * tol)
        for offset in (0.0, 1e3):
            for f in (0.5, 0.999999, 1.0, 1.000001, 1.0001, 2.0, 1e3):
                s = _bumped(2.0 * f * limit, offset, rational)
                want = face_mod._plane_offset_numpy(s, tol)
                assert _same_plane(face_mod._plane_offset(s, tol), want), (tol, offset, f)
                said = _kernel_says_curved(s, tol)
                assert not (said and want is not None), (tol, offset, f)
                n_plane += want is not None
                n_none += want is None
                n_settled += said
                if f >= 2.0:
                    assert said, (tol, offset, f)        # clearly curved: settled at once
    assert n_plane >= 4 and n_none >= 8 and n_settled >= 4


def test_triangle_switches_give_the_same_triangulation(shared_data):
    """Triangle with the compiled path's switches (`TRIANGLE_OPTS`, segments as C int) gives the points and
    triangles of `tr.triangulate(..., "pQ")` on every call a tessellation of two models makes."""
    import triangle as tr

    from trimsurf.tessellate import tessellate_shell

    calls = []
    real = grid_mod._triang

    def rec(d, opts):
        calls.append({k: np.array(v) for k, v in d.items()})
        assert opts == grid_mod.TRIANGLE_OPTS and d["segmentlist"].dtype == np.intc
        return real(d, opts)

    grid_mod._triang = rec
    try:
        for name in ("occt__screw.step", "gmsh__t20_data.step"):
            shell = read_shell(shared_data / "cad" / name)
            d = shell.diagonal()
            tessellate_shell(shell, tolerance=1e-3 * d, max_edge=3e-2 * d, measure=False)
    finally:
        grid_mod._triang = real
    assert len(calls) > 20
    for c in calls:
        got, _ = real(c, grid_mod.TRIANGLE_OPTS)
        want = tr.triangulate({"vertices": c["pointlist"], "segments": c["segmentlist"].astype(np.int64)}, "pQ")
        assert np.array_equal(got["pointlist"], want["vertices"])
        assert np.array_equal(got["trianglelist"], want["triangles"])
        assert got["trianglelist"].dtype == np.intc and set(got) == {"pointlist", "trianglelist"}


def test_sliver_checks_equal_numpy(shared_data, monkeypatch):
    """`slivers._check` (the moved triangles' corners, (u, v) sense, sides and cosines in one compiled pass)
    equals `_check_numpy` on every call the sliver rounds of four models make (default and larger angles,
    looser tolerances: collapses refused by each test and taken), and on the same calls with a short
    max_edge, a flipped sense and NaN / inf points."""
    from trimsurf.tessellate import slivers as sl
    from trimsurf.tessellate import tessellate_shell

    calls = []
    real = sl._check

    def rec(*a):
        calls.append(a)
        return real(*a)

    monkeypatch.setattr(sl, "_check", rec)
    # the aspect limit on developable faces too (the rule before session 29): more sliver checks tol-only
    import trimsurf.tessellate.face as face_mod
    monkeypatch.setattr(face_mod, "LIMIT_DEVELOPABLE", True)
    for name in ("gmsh__t20_data.step", "occt__screw.step", "trimesh__featuretype.STEP", "gmsh__U_Joint_2.stp"):
        shell = read_shell(shared_data / "cad" / name)
        d = shell.diagonal()
        tessellate_shell(shell, tolerance=1e-3 * d, max_edge=d, measure=False)
    monkeypatch.setattr(sl, "_check", real)
    assert len(calls) > 100
    n = {"refused": 0, "taken": 0, "edge": 0, "nan": 0, "flat": 0}
    for a in calls:
        surface, uv, xyz, T, cv, cu, a0, mi, ci, sgn, tol, max_edge = a
        variants = [a]
        if len(mi):
            e = np.linalg.norm(xyz[T[mi]] - np.roll(xyz[T[mi]], 1, axis=1), axis=2)
            variants.append((surface, uv, xyz, T, cv, cu, a0, mi, ci, sgn, tol, float(np.median(e))))
            variants.append((surface, uv, xyz, T, cv, cu, a0 * 0.5, mi, ci, -sgn, 100 * tol, max_edge))
            variants.append((surface, uv, xyz, T, cv, cu, a0 * 0.5, mi, ci, sgn, 100 * tol, np.inf))
            bad_x = xyz.copy()
            bad_x[T[mi[0], 0]] = np.nan
            bad_x[T[mi[-1], 1], 2] = np.inf
            variants.append((surface, uv, bad_x, T, cv, cu, a0 * 0.5, mi, ci, sgn, 100 * tol, max_edge))
            # a NaN side with the others longer than max_edge: numpy's max is NaN, no failure
            variants.append((surface, uv, bad_x, T, cv, cu, a0 * 0.5, mi, ci, sgn, 100 * tol, 0.0))
            # a moved triangle of no (u, v) area: refused (area * sgn <= 0)
            t0 = np.where(T[mi[0]] == cv[ci[0]], cu[ci[0]], T[mi[0]])
            flat_uv = uv.copy()
            flat_uv[t0[2]] = flat_uv[t0[1]] if t0[2] != cu[ci[0]] else flat_uv[t0[0]]
            variants.append((surface, flat_uv, xyz, T, cv, cu, a0 * 0.5, mi, ci, sgn, 100 * tol, np.inf))
        for k, v in enumerate(variants):
            with np.errstate(all="ignore"):
                got, want = sl._check(*v), sl._check_numpy(*v)
            assert got.dtype == want.dtype == np.bool_ and np.array_equal(got, want), k
            n["refused"] += int((~want).sum())
            n["taken"] += int(want.sum())
            n["edge"] += k == 1 and not want.all()
            n["nan"] += k == 5 and not want.all()
            n["flat"] += k == 6 and not want[ci[0]]
    assert n["refused"] > 100 and n["taken"] > 20 and n["edge"] > 20 and n["nan"] > 20 and n["flat"] > 20, n

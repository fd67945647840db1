"""Common parameterization (paper Fig. 12): iso-lines end at the same points on both sides of an edge."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from trimsurf.geom.knots import bezier_extract_surface
from trimsurf.io import read_shell, write_shell
from trimsurf.model import NurbsSurface, Shell, TrimmedFace
from trimsurf.quality import topology_report
from trimsurf.samples import build_sample
from trimsurf.tessellate import tessellate_shell
from trimsurf.tessellate.common import common_parameterization, iso_axis, merge_finest
from trimsurf.tessellate.face import face_domain_values


def _iso_ends(face, seg, values):
    """Edge parameters where the face's transversal lines `values` meet the p-curve `seg` (dense inverse)."""
    ax = iso_axis(seg, face.surface)
    lo, hi = sorted((seg.t0, seg.t1))
    t = np.linspace(lo, hi, 20001)
    x = seg.curve.evaluate(t)[:, ax]
    g = values[(values > x.min()) & (values < x.max())]
    order = np.argsort(x)
    return np.sort(np.interp(g, x[order], t[order])), hi - lo


def _unmatched(a, b, tol):
    """Points of a with no point of b within tol, and vice versa."""
    if not len(a) or not len(b):
        return len(a) + len(b)
    d = np.abs(a[:, None] - b[None, :])
    return int((d.min(axis=1) > tol).sum() + (d.min(axis=0) > tol).sum())


def test_box_iso_lines_meet_across_shared_edges():
    shell = build_sample("bspline_box")
    d = shell.diagonal()
    faces = list(shell.faces)
    grids = {i: face_domain_values(f, tolerance=1e-3 * d, max_edge=0.03 * d) for i, f in enumerate(faces)}
    before = {i: (u.copy(), v.copy()) for i, (u, v) in grids.items()}
    # the box's edges are creases: by default (tangent-continuous joints only) nothing is linked
    assert common_parameterization(shell, faces, {i: g for i, g in grids.items()}) == set()
    changed = common_parameterization(shell, faces, grids, max_angle_deg=180.0)
    assert changed                           # (a face whose lines already were the merged set is unchanged)
    n_before = n_after = 0
    for edge in shell.edges:
        (fa, la, sa), (fb, lb, sb) = edge.uses
        pa, pb = faces[fa].loops[la].segments[sa], faces[fb].loops[lb].segments[sb]
        ax_a, ax_b = iso_axis(pa, faces[fa].surface), iso_axis(pb, faces[fb].surface)
        ta, span = _iso_ends(faces[fa], pa, grids[fa][ax_a])
        tb, _ = _iso_ends(faces[fb], pb, grids[fb][ax_b])
        assert len(ta) > 3
        # every line ends where a line of the other face ends (to the dense inverse's precision)
        assert _unmatched(ta, tb, 1e-6 * span) == 0
        ba, _ = _iso_ends(faces[fa], pa, before[fa][ax_a])
        bb, _ = _iso_ends(faces[fb], pb, before[fb][ax_b])
        n_after += len(ta)
        n_before += max(len(ba), len(bb))
    # one set of lines per ring of faces, about as fine as its finest face: not the union of both
    # sides' sets (which doubled the triangles)
    assert n_after <= 1.1 * n_before


def test_merge_finest_is_a_subset_nowhere_coarser_than_any_set():
    rng = np.random.default_rng(7)
    for _ in range(20):
        sets = [np.sort(rng.uniform(0, 1, rng.integers(3, 30))) for _ in range(3)]
        sets[1] = sets[1][sets[1] < 0.6]                 # a set that covers only part of the range
        out = merge_finest(sets, 0.0, 1.0)
        assert out[0] == 0.0 and out[-1] == 1.0 and np.all(np.diff(out) > 0)
        union = np.unique(np.concatenate(sets + [np.array([0.0, 1.0])]))
        # values of the union, or the mean of a cluster of nearly coincident ones
        assert np.all((out >= 0) & (out <= 1))
        for s in sets:
            if len(s) < 2:
                continue
            mid = 0.5 * (out[:-1] + out[1:])
            k = np.searchsorted(s, mid)
            cov = (k > 0) & (k < len(s))
            own = s[np.clip(k, 1, len(s) - 1)] - s[np.clip(k, 1, len(s) - 1) - 1]
            # a merged step no longer than the set's own interval there, up to the slack and the
            # clustering (a cluster's mean moves a line by at most 0.3 of the local spacing)
            assert np.all(np.diff(out)[cov] <= 1.1 * 1.6 * own[cov] + 1e-12)
        assert len(out) <= len(union)


@pytest.mark.parametrize("name", ["occt__screw.step", "gmsh__wrenchnut.stp"])
def test_common_parameterization_stays_watertight(shared_data, name):
    """The union of both sides' values cracked these (screw 88 boundary edges, wrenchnut 12 and 59 non-manifold)."""
    shell = read_shell(shared_data / "cad" / name)
    d = shell.diagonal()
    res = tessellate_shell(shell, tolerance=1e-3 * d, max_edge=3e-2 * d, common=True, measure=False)
    assert res.ok and res.report["faces_common_parameterization"] > 0
    topo = topology_report(res.mesh)
    assert topo.n_boundary_edges == 0 and topo.n_non_manifold_edges == 0 and topo.is_consistently_oriented


def _patch_faces(name: str) -> list:
    """A sample's surface cut into its Bezier patches: one untrimmed face each, named P<i><j>."""
    s = build_sample(name).faces[0].surface
    bp = bezier_extract_surface(s.degree_u, s.degree_v, s.knots_u, s.knots_v, s.control_points, s.weights)
    du, dv = s.degree_u, s.degree_v
    faces = []
    for i in range(bp.control_points.shape[0]):
        for j in range(bp.control_points.shape[1]):
            ku = np.r_[[bp.u_breaks[i]] * (du + 1), [bp.u_breaks[i + 1]] * (du + 1)]
            kv = np.r_[[bp.v_breaks[j]] * (dv + 1), [bp.v_breaks[j + 1]] * (dv + 1)]
            faces.append(TrimmedFace(NurbsSurface(du, dv, ku, kv, bp.control_points[i, j]), name=f"P{i}{j}"))
    return faces


def _patch_shell(tmp_path, name: str) -> Shell:
    """A sample's surface cut into its Bezier patches, one untrimmed face each, sewn through STEP."""
    faces = _patch_faces(name)
    path = tmp_path / f"{name}.step"
    write_shell(Shell.from_faces(faces), path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return read_shell(path)


def _grid_lines_meeting(shell, res) -> tuple[int, int]:
    """(unmatched, total) grid-line ends on the shared iso-parametric edges of a tessellation."""
    bad = tot = 0
    for e in shell.edges:
        if len(e.uses) != 2:
            continue
        ends = []
        for fi, li, si in e.uses:
            face, fm = shell.faces[fi], res.face_meshes[fi]
            seg = face.loops[li].segments[si]
            ax = iso_axis(seg, face.surface)
            vals, cnt = np.unique(fm.uv[:, ax], return_counts=True)
            ends.append(_iso_ends(face, seg, vals[cnt >= 3]))       # grid lines: 3 or more vertices
        (a, span), (b, _) = ends
        bad += _unmatched(a, b, 1e-6 * span)
        tot += len(a) + len(b)
    return bad, tot


def test_patch_grid_highlight_lines_run_on(tmp_path):
    """Fig. 12: the fender cut into its 18 Bezier patches. Separately, the patches' iso-lines mostly
    end at different points of a shared edge; with the common parameterization they meet (refinement
    of a single cell may still add a line that ends there), within the tolerance and without flips."""
    shell = _patch_shell(tmp_path, "fender")
    assert len(shell.faces) == 18 and sum(len(e.uses) == 2 for e in shell.edges) > 20
    d = shell.diagonal()
    out = {}
    for common in (False, True):
        res = tessellate_shell(shell, tolerance=1e-3 * d, max_edge=3e-2 * d, common=common)
        assert res.mode == "conforming" and res.report["max_deviation"] <= res.tolerance
        assert res.report["flipped"] == 0 and res.report["nonmanifold_edges"] == 0
        assert topology_report(res.mesh).n_boundary_loops == 1        # one sheet, no cracks between patches
        out[common] = _grid_lines_meeting(shell, res)
    (bad0, tot0), (bad1, tot1) = out[False], out[True]
    assert bad0 > 0.5 * tot0
    assert bad1 <= 0.05 * tot1


def test_loose_patches_lines_meet_in_3d(tmp_path):
    """A VDA-FS model has no shared edges: iso-parametric loop segments of different faces that run
    along each other within the tolerance are linked through closest points, so the lines of the
    fender's 18 patches end at the same 3D points (within the half tolerance stitching bridges)."""
    faces = _patch_faces("fender")
    path = tmp_path / "fender.vda"
    write_shell(Shell.from_faces(faces), path)
    shell = read_shell(path)
    assert not shell.edges
    from trimsurf.tessellate.face import _rectangle_face

    faces = [_rectangle_face(f) for f in shell.faces]
    d = shell.diagonal()
    tol, h = 0.5e-3 * d, 3e-2 * d

    def ends(grids):
        """3D ends of the interior grid lines on the patches' inner sides, per face."""
        out = []
        for i, f in enumerate(faces):
            us, vs = grids[i]
            pts = []
            for axis, vals, sides in ((0, us[1:-1], vs[[0, -1]]), (1, vs[1:-1], us[[0, -1]])):
                for c in sides:
                    if c in (0.0, 1.0):                       # the outer boundary of the fender
                        continue
                    uv = np.column_stack([vals, np.full(len(vals), c)] if axis == 0 else [np.full(len(vals), c), vals])
                    pts.append(f.surface.evaluate(uv))
            out.append(np.concatenate(pts))
        return out

    def unmatched(grids):
        e = ends(grids)
        bad = tot = 0
        for i, p in enumerate(e):
            other = np.concatenate([q for k, q in enumerate(e) if k != i])
            dist = np.linalg.norm(p[:, None] - other[None], axis=-1).min(axis=1)
            bad += int((dist > tol).sum())
            tot += len(p)
        return bad, tot

    grids = {i: face_domain_values(f, tolerance=tol, max_edge=h) for i, f in enumerate(faces)}
    bad0, tot0 = unmatched(grids)
    # without a tolerance (no topology) nothing is linked
    assert common_parameterization(shell, faces, dict(grids)) == set()
    changed = common_parameterization(shell, faces, grids, tolerance=tol)
    assert len(changed) == len(faces)
    bad1, tot1 = unmatched(grids)
    assert bad0 > 0.1 * tot0 and bad1 == 0

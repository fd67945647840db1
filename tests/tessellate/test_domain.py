"""Domain values and cell splits (paper Sec. 4.2, 5.1): both criteria on every interval, no more
values than needed, deviations measured to the surface, one diagonal direction where both fit alike."""

from __future__ import annotations

import numpy as np
import pytest

from trimsurf.errors import InputError
from trimsurf.model import NurbsSurface, TrimmedFace
from trimsurf.samples import build_sample
from trimsurf.tessellate.domain import adaptive_values, interval_criteria
from trimsurf.tessellate.face import (ASPECT, _rectangle_face, check_aspect, face_domain_values, loose_chunks,
                                      mesh_face_from_chunks, surface_distance, triangle_deviation)


def _ellipse(t):
    """An ellipse with semi-axes 3 and 1 (curvature varies 27-fold along it), one line."""
    return np.stack([3.0 * np.cos(t), np.sin(t), 0.0 * t], axis=-1)[:, None, :]


def _half_cylinder(radius: float = 10.0, height: float = 40.0, twist_deg: float = 0.0) -> NurbsSurface:
    """Half cylinder of rational quadratic arcs (u: the arc, two spans, non-uniform speed), v: axis; with
    `twist_deg` its top arc turned by that angle about the axis (a hyperboloid: straight lines along v,
    the normal turning along them, not developable)."""
    w = np.sqrt(0.5)
    arc = np.array([[1, 0], [1, 1], [0, 1], [-1, 1], [-1, 0]], dtype=np.float64) * radius
    c, s = np.cos(np.radians(twist_deg)), np.sin(np.radians(twist_deg))
    cp = np.array([[[x, y, 0.0], [c * x - s * y, s * x + c * y, height]] for x, y in arc])
    weights = np.array([[1.0, 1.0], [w, w], [1.0, 1.0], [w, w], [1.0, 1.0]])
    return NurbsSurface(2, 1, [0, 0, 0, 0.5, 0.5, 1, 1, 1], [0, 0, 1, 1], cp, weights)


@pytest.mark.parametrize("tol", [1e-2, 1e-3])
def test_equidistributed_meets_both_criteria_with_fewest_values(tol):
    """Every interval meets both criteria; the equidistributed values are no more than the paper's
    bisection gives, and (on a curve of varying curvature) fewer than the uniform baseline's."""
    h = 0.5
    x = adaptive_values(_ellipse, 0.0, np.pi, tolerance=tol, max_edge=h)
    length, dev = interval_criteria(_ellipse, x, n_sub=24)
    assert length.max() <= h and dev.max() <= tol * 1.01     # 24 sub-samples: the 6 of the check, and between
    xb = adaptive_values(_ellipse, 0.0, np.pi, tolerance=tol, max_edge=h, strategy="bisection")
    xu = adaptive_values(_ellipse, 0.0, np.pi, tolerance=tol, max_edge=h, strategy="uniform")
    assert len(x) <= len(xb)
    assert len(x) < len(xu)


def test_circle_needs_exactly_the_sagitta_count():
    """On a circle (constant curvature) the fewest equal chords within the tolerance is known in
    closed form: n = ceil(pi / (2 acos(1 - tol / R))) over a half turn; equidistribution finds it."""
    r, tol = 5.0, 1e-3

    def circle(t):
        return np.stack([r * np.cos(t), r * np.sin(t), 0.0 * t], axis=-1)[:, None, :]

    x = adaptive_values(circle, 0.0, np.pi, tolerance=tol, max_edge=100.0)
    n_min = int(np.ceil(np.pi / (2.0 * np.arccos(1.0 - tol / r))))
    assert len(x) - 1 == n_min


def _skewed_quarter_cylinder(radius: float = 10.0, height: float = 40.0, c: float = 3.0) -> NurbsSurface:
    """A quarter cylinder whose rational arc is reparameterized (weights 1, c w, c^2): the same
    surface, the speed along u varying several-fold (u = 0.5 lies at 68 degrees, not 45)."""
    w = np.sqrt(0.5)
    arc = np.array([[1, 0], [1, 1], [0, 1]], dtype=np.float64) * radius
    cp = np.array([[[x, y, 0.0], [x, y, height]] for x, y in arc])
    weights = np.array([[1.0, 1.0], [c * w, c * w], [c * c, c * c]])
    return NurbsSurface(2, 1, [0, 0, 0, 1, 1, 1], [0, 0, 1, 1], cp, weights)


@pytest.mark.parametrize("u0, u1", [(0.2, 0.4), (0.4, 0.6), (0.6, 0.9)])
def test_triangle_deviation_is_distance_to_surface_not_parameter_offset(u0, u1):
    """S(uv) at a triangle's interpolated uv is not the closest surface point where the speed varies:
    the deviation bound is the distance to the foot point, so for a cell of a cylinder split along a
    diagonal it is the chord's sagitta R (1 - cos(theta / 2)), not up to 2.7x that."""
    r = 10.0
    s = _skewed_quarter_cylinder(r)
    uv = np.array([[u0, 0.2], [u1, 0.2], [u1, 0.8], [u0, 0.8]])
    xyz = s.evaluate(uv)
    tris = np.array([[0, 1, 2], [0, 2, 3]])
    ang = np.arctan2(xyz[1, 1], xyz[1, 0]) - np.arctan2(xyz[0, 1], xyz[0, 0])
    sagitta = r * (1.0 - np.cos(0.5 * ang))
    dev = triangle_deviation(s, uv, xyz, tris)
    assert np.all(dev <= sagitta * (1 + 1e-6))
    assert dev.max() >= 0.99 * sagitta               # the edge midpoints are sampled
    # the plain parameter offset |S(uv) - x| at the chord's midpoint: what the bound no longer counts
    mid = 0.5 * (uv[0] + uv[1])
    x_mid = 0.5 * (xyz[0] + xyz[1])
    assert np.linalg.norm(s.evaluate(mid[None])[0] - x_mid) > 1.3 * sagitta
    assert surface_distance(s, mid[None], x_mid[None])[0] <= sagitta * (1 + 1e-6)


def test_cylinder_cells_take_one_diagonal_direction():
    """Both diagonals of a cylinder cell fit the surface exactly alike; a near tie must not flip the
    direction from cell to cell (the reflection lines would wander): every grid cell, untouched or
    triangulated with the trims, is cut along the same diagonal direction."""
    s = _half_cylinder()
    face = _rectangle_face(TrimmedFace(s))
    tol, h = 0.02, 100.0
    us, vs = face_domain_values(face, tolerance=tol, max_edge=h)
    assert len(us) > 8
    fm = mesh_face_from_chunks(face, us, vs, loose_chunks(face, 0, us, vs, tolerance=tol, max_edge=h,
                                                          strategy="equidistributed"),
                               tolerance=tol, max_edge=h, slivers=False)
    e = np.concatenate([fm.triangles[:, [0, 1]], fm.triangles[:, [1, 2]], fm.triangles[:, [2, 0]]])
    a, b = fm.uv[e[:, 0]], fm.uv[e[:, 1]]
    iu_a, iu_b = np.searchsorted(us, a[:, 0]), np.searchsorted(us, b[:, 0])
    jv_a, jv_b = np.searchsorted(vs, a[:, 1]), np.searchsorted(vs, b[:, 1])
    node = (np.isin(a[:, 0], us) & np.isin(a[:, 1], vs) & np.isin(b[:, 0], us) & np.isin(b[:, 1], vs))
    diag = node & (np.abs(iu_a - iu_b) == 1) & (np.abs(jv_a - jv_b) == 1)
    assert diag.sum() >= (len(us) - 1) * (len(vs) - 1)        # every cell's diagonal (each edge twice)
    direction = np.sign((iu_b - iu_a) * (jv_b - jv_a))[diag]
    assert np.all(direction == direction[0])
    assert np.all(fm.tri_dev <= tol)


@pytest.mark.parametrize("name", ["fender", "hood"])
def test_every_triangle_within_tolerance_at_its_samples(name):
    """The per-face guarantee the assembly builds on: every triangle's deviation bound, crossed cells
    included (a CDT triangle that left it gets an interior point), is within the tolerance."""
    shell = build_sample(name)
    face = shell.faces[0]
    tol, h = 1e-3 * shell.diagonal(), shell.diagonal()
    us, vs = face_domain_values(face, tolerance=tol, max_edge=h)
    fm = mesh_face_from_chunks(face, us, vs, loose_chunks(face, 0, us, vs, tolerance=tol, max_edge=h,
                                                          strategy="equidistributed"),
                               tolerance=tol, max_edge=h)
    assert len(fm.triangles) > 50
    assert fm.tri_dev.max() <= tol


def test_tolerance_only_cylinder_cells_keep_their_aspect():
    """With only the deviation criterion a (slightly twisted) cylinder's straight direction needs no
    line at all: one cell would span its whole length and its triangles' smallest angle would be
    atan(chord / length) (under 2 degrees here). Cells are halved across their long side down to the
    aspect ASPECT, so the grid triangles' smallest angle is at least about atan(1 / ASPECT). (An exact
    cylinder is developable and not limited: `test_developable_faces_are_not_limited`.)"""
    s = _half_cylinder(radius=10.0, height=400.0, twist_deg=0.5)
    face = _rectangle_face(TrimmedFace(s))
    tol, h = 0.05, 1e4
    us, vs = face_domain_values(face, tolerance=tol, max_edge=h)
    uu, vv = np.meshgrid(us, vs, indexing="ij")
    p = s.evaluate(np.column_stack([uu.ravel(), vv.ravel()])).reshape(len(us), len(vs), 3)
    side_u = np.linalg.norm(np.diff(p, axis=0), axis=2)[:, :-1]
    side_v = np.linalg.norm(np.diff(p, axis=1), axis=2)[:-1, :]
    ratio = np.maximum(side_u, side_v) / np.minimum(side_u, side_v)
    assert len(vs) > 2 and ratio.max() <= ASPECT
    fm = mesh_face_from_chunks(face, us, vs, loose_chunks(face, 0, us, vs, tolerance=tol, max_edge=h,
                                                          strategy="equidistributed"),
                               tolerance=tol, max_edge=h)
    q = fm.xyz[fm.triangles]
    e = np.linalg.norm(q - np.roll(q, 1, axis=1), axis=2)
    # smallest angle from the sides: opposite the shortest side, law of cosines
    a, b, c = np.sort(e, axis=1).T
    ang = np.degrees(np.arccos(np.clip((b * b + c * c - a * a) / (2 * b * c), -1, 1)))
    assert np.percentile(ang, 5) >= 0.9 * np.degrees(np.arctan(1.0 / ASPECT))
    assert fm.tri_dev.max() <= tol


@pytest.mark.parametrize("aspect", [4.0, 12.0, None])
def test_aspect_parameter_bounds_the_cells(aspect):
    """`aspect` is the limit the cells are halved down to: a tolerance-only grid on a long cylinder ends
    with side ratios in (aspect / 2, aspect] (halving the long side halves the ratio; refine_cells runs at
    most 6 rounds, 64 cells along this 400 long line: 4 is reached, 3 would not be), or, with no limit,
    one cell along the whole straight direction; every setting within the tolerance."""
    s = _half_cylinder(radius=10.0, height=400.0, twist_deg=0.5)
    face = _rectangle_face(TrimmedFace(s))
    tol, h = 0.05, 1e4
    us, vs = face_domain_values(face, tolerance=tol, max_edge=h, aspect=aspect)
    uu, vv = np.meshgrid(us, vs, indexing="ij")
    p = s.evaluate(np.column_stack([uu.ravel(), vv.ravel()])).reshape(len(us), len(vs), 3)
    side_u = np.linalg.norm(np.diff(p, axis=0), axis=2)[:, :-1]
    side_v = np.linalg.norm(np.diff(p, axis=1), axis=2)[:-1, :]
    ratio = np.maximum(side_u, side_v) / np.minimum(side_u, side_v)
    if aspect is None:
        assert len(vs) == 2 and ratio.max() > 50
    else:
        assert aspect / 2 < ratio.max() <= aspect
    fm = mesh_face_from_chunks(face, us, vs, loose_chunks(face, 0, us, vs, tolerance=tol, max_edge=h,
                                                          strategy="equidistributed"),
                               tolerance=tol, max_edge=h)
    assert fm.tri_dev.max() <= tol
    # the default is ASPECT; inf is no limit
    if aspect is None:
        assert np.array_equal(face_domain_values(face, tolerance=tol, max_edge=h, aspect=float("inf"))[1], vs)
    assert np.array_equal(face_domain_values(face, tolerance=tol, max_edge=h, aspect=ASPECT)[1],
                          face_domain_values(face, tolerance=tol, max_edge=h)[1])


def _cell_ratios(s, us, vs):
    uu, vv = np.meshgrid(us, vs, indexing="ij")
    p = s.evaluate(np.column_stack([uu.ravel(), vv.ravel()])).reshape(len(us), len(vs), 3)
    side_u = np.linalg.norm(np.diff(p, axis=0), axis=2)[:, :-1]
    side_v = np.linalg.norm(np.diff(p, axis=1), axis=2)[:-1, :]
    return np.maximum(side_u, side_v) / np.minimum(side_u, side_v)


def test_developable_faces_are_not_limited(monkeypatch):
    """An exact cylinder's normal is the same all along each of its lines, so a cell as long as the
    cylinder shades exactly: without LIMIT_DEVELOPABLE no aspect limit there (one cell along the 400 long
    line, within the tolerance); with it the limit applies as on other faces."""
    import trimsurf.tessellate.face as F

    monkeypatch.setattr(F, "LIMIT_DEVELOPABLE", False)
    s = _half_cylinder(radius=10.0, height=400.0)
    face = _rectangle_face(TrimmedFace(s))
    tol, h = 0.05, 1e4
    us, vs = face_domain_values(face, tolerance=tol, max_edge=h)
    assert len(vs) == 2 and _cell_ratios(s, us, vs).max() > 50
    fm = mesh_face_from_chunks(face, us, vs, loose_chunks(face, 0, us, vs, tolerance=tol, max_edge=h,
                                                          strategy="equidistributed"),
                               tolerance=tol, max_edge=h)
    assert fm.tri_dev.max() <= tol
    monkeypatch.setattr(F, "LIMIT_DEVELOPABLE", True)
    us2, vs2 = face_domain_values(face, tolerance=tol, max_edge=h)
    assert len(vs2) > 2 and _cell_ratios(s, us2, vs2).max() <= ASPECT


def test_developable_surfaces():
    """`_developable`: straight lines whose two control rows are one scaled (lam > 0) or moved copy of the
    other with the same weights: cylinder, cone, plane yes; a twisted cylinder, a bilinear twist, a cone
    through its apex (lam < 0), rows with other weights, a surface curved both ways no."""
    from trimsurf.tessellate.face import _developable

    cyl = _half_cylinder()
    assert _developable(cyl)
    cp = cyl.control_points.copy()
    cone = NurbsSurface(2, 1, cyl.knots_u, cyl.knots_v, np.stack([cp[:, 0], 0.4 * cp[:, 0] + [0, 0, 30]], axis=1),
                        cyl.weights)
    assert _developable(cone)
    through = NurbsSurface(2, 1, cyl.knots_u, cyl.knots_v, np.stack([cp[:, 0], -0.4 * cp[:, 0] + [0, 0, 30]], axis=1),
                           cyl.weights)
    assert not _developable(through)
    w = cyl.weights.copy()
    w[1, 1] = 0.5
    assert not _developable(NurbsSurface(2, 1, cyl.knots_u, cyl.knots_v, cp, w))
    assert not _developable(_half_cylinder(twist_deg=0.5))
    plane = NurbsSurface(1, 1, [0, 0, 1, 1], [0, 0, 1, 1], [[[0, 0, 0], [0, 1, 0]], [[1, 0, 0], [1, 1, 0]]])
    assert _developable(plane)
    twist = NurbsSurface(1, 1, [0, 0, 1, 1], [0, 0, 1, 1], [[[0, 0, 0], [0, 1, 0]], [[1, 0, 0], [1, 1, 0.2]]])
    assert not _developable(twist)
    g = np.linspace(0, 1, 3)
    dome = NurbsSurface(2, 2, [0, 0, 0, 1, 1, 1], [0, 0, 0, 1, 1, 1],
                        [[[x, y, 1 - (x - 0.5) ** 2 - (y - 0.5) ** 2] for y in g] for x in g])
    assert not _developable(dome)


@pytest.mark.parametrize("bad", [0.5, 0.0, -3.0, float("nan"), "six", [6]])
def test_check_aspect_refuses_bad_values(bad):
    with pytest.raises(InputError, match="aspect"):
        check_aspect(bad)


@pytest.mark.parametrize("name", ["fender", "hood"])
def test_adaptive_values_no_more_triangles_than_the_uniform_baseline(name):
    """The paper's adaptive domain values exist to need fewer lines than its uniform baseline (Sec. 3.4)
    at the same tolerance. Before, the equidistributed lines plus bisection of every failing interval
    and a mid-line in both directions through every cell that left the tolerance gave 262 triangles
    on the fender where the uniform grid gave 207. Measured against the true face, within tolerance."""
    from trimsurf.quality import surface_deviation
    from trimsurf.tessellate import tessellate_face

    shell = build_sample(name)
    face = shell.faces[0]
    tol, h = 1e-3 * shell.diagonal(), shell.diagonal()
    adaptive = tessellate_face(face, tolerance=tol, max_edge=h)
    uniform = tessellate_face(face, tolerance=tol, max_edge=h, strategy="uniform")
    assert adaptive.n_triangles <= 1.1 * uniform.n_triangles
    assert surface_deviation(adaptive, face, density=4).max_two_sided <= tol


def test_domain_values_fits_are_the_diagonal_fits(shared_data):
    """The diagonal fits `face_domain_values(..., with_fits=True)` hands to `mesh_face_from_chunks` (from
    its cell cache) are bit for bit `_diagonal_fits` of the returned grid, also where the refinement's
    last round added cells the cache had not seen (wing_fuselage at loose mode's face tolerance)."""
    from trimsurf.errors import InputError
    from trimsurf.io import read_shell
    from trimsurf.tessellate.face import _diagonal_fits
    from trimsurf.tessellate.shell import default_parameters

    shell = read_shell(shared_data / "cad" / "gmsh__wing_fuselage.step")
    tol, h = default_parameters(shell)
    n = 0
    for f in shell.faces:
        f = f if f.loops else _rectangle_face(f)
        try:
            us, vs, fits = face_domain_values(f, tolerance=0.5 * tol, max_edge=h, with_fits=True)
        except InputError:
            continue
        ref = _diagonal_fits(f.surface, us, vs)
        assert fits.shape == ref.shape and np.array_equal(fits.view(np.uint64), ref.view(np.uint64))
        n += 1
    assert n >= 0.9 * len(shell.faces)

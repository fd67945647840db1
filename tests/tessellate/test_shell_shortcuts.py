"""The shell-level stages' shortcuts (seam reduction, stitching) give the very results of what they replace."""
import numpy as np
import pytest

from trimsurf.model import NurbsSurface, TrimmedFace
from trimsurf.tessellate.seams import _against_normal, _normals, _planar_cone, _surely_along
from trimsurf.tessellate.stitch import _sequential_fans, _triangulate_polygon


def _rotation(rng):
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return q


def _flat_surface(rng, pu, pv, nu, nv, offset=1e3, warp=0.0):
    """A non-rational surface whose net lies in a rotated plane far from the origin (monotone net)."""
    ku = np.r_[np.zeros(pu), np.linspace(0.0, 1.0, nu - pu + 1) ** 1.3, np.ones(pu)] * 7.0 - 2.0
    kv = np.r_[np.zeros(pv), np.linspace(0.0, 1.0, nv - pv + 1), np.ones(pv)] * 0.3
    x, y = np.meshgrid(np.cumsum(rng.uniform(0.5, 1.5, nu)), np.cumsum(rng.uniform(0.5, 1.5, nv)), indexing="ij")
    z = warp * rng.normal(size=x.shape)
    P = np.stack([x, y, z], axis=-1) @ _rotation(rng).T + offset * rng.normal(size=3)
    return NurbsSurface(pu, pv, ku, kv, P)


@pytest.mark.parametrize("pu,pv,nu,nv", [(1, 1, 2, 2), (1, 1, 4, 3), (3, 3, 4, 4), (3, 1, 7, 2), (2, 3, 5, 6)])
def test_planar_cone_bounds_the_computed_normals(pu, pv, nu, nv):
    rng = np.random.default_rng(pu * 100 + nu * 10 + nv)
    for k in range(6):
        s = _flat_surface(rng, pu, pv, nu, nv, warp=(0.0, 1e-9, 1e-4)[k % 3])     # also nearly flat nets
        cone = _planar_cone(s)
        assert cone is not None
        n0, alpha = cone
        (u0, u1), (v0, v1) = s.domain
        uv = np.column_stack([rng.uniform(u0, u1, 4000), rng.uniform(v0, v1, 4000)])
        uv = np.r_[uv, [[u0, v0], [u1, v1], [u0, v1], [u1, v0]], s.knots_u[pu:-pu][:, None] * [1, 0] + [0, v0]]
        n = s.normals(uv)
        assert np.all(np.isfinite(n))
        angle = np.arctan2(np.linalg.norm(np.cross(n, n0), axis=1), n @ n0)    # (accurate near 0)
        assert float(angle.max()) <= alpha + 1e-12          # (+ the normalisation's rounding)


def test_planar_cone_refuses_curved_rational_and_degenerate_nets():
    rng = np.random.default_rng(3)
    assert _planar_cone(_flat_surface(rng, 3, 3, 4, 4, warp=0.3)) is None
    s = _flat_surface(rng, 2, 1, 3, 2)
    assert _planar_cone(NurbsSurface(2, 1, s.knots_u, s.knots_v, s.control_points,
                                     np.array([[1.0, 1.0], [0.7, 0.7], [1.0, 1.0]]))) is None
    P = s.control_points.copy()
    P[:, 0] = P[0, 0]                       # a collapsed edge (a pole): zero cross products
    assert _planar_cone(NurbsSurface(2, 1, s.knots_u, s.knots_v, P)) is None


def _against_normal_reference(faces, face_of, uv3, tri_normals):
    """The flip test as main computed it: every sample point through the face's public method."""
    bary = np.array([[1 / 3, 1 / 3, 1 / 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    pts = np.einsum("bj,rjk->rbk", bary, uv3)
    ns = np.empty(pts.shape[:2] + (3,))
    with np.errstate(all="ignore"):
        for f in np.unique(face_of).tolist():
            r = np.flatnonzero(face_of == f)
            ns[r] = faces[f].oriented_normals(pts[r].reshape(-1, 2)).reshape(len(r), -1, 3)
        dot = np.einsum("rbk,rk->rb", ns, tri_normals)
        valid = np.isfinite(dot) & (np.linalg.norm(ns, axis=2) > 0.5)
    return np.any(valid & ~(dot > 0), axis=1)


def test_against_normal_is_the_per_face_evaluation():
    """Flat and curved faces, both senses, triangles at every angle (also grazing) to the surface,
    shared corners with equal and with different (u, v) (a periodic seam): the batched test with its
    flat-face shortcut and per-vertex corner evaluation flags exactly the triangles main flagged."""
    rng = np.random.default_rng(11)
    faces = [TrimmedFace(_flat_surface(rng, 1, 1, 2, 2), same_sense=True),
             TrimmedFace(_flat_surface(rng, 3, 1, 7, 2), same_sense=False),
             TrimmedFace(_flat_surface(rng, 3, 3, 4, 4, warp=0.4), same_sense=True),
             TrimmedFace(_flat_surface(rng, 2, 2, 3, 3, warp=1.0), same_sense=False)]
    nv, m = 300, 4000
    face_of = rng.integers(0, len(faces), m)
    corners = rng.integers(0, nv, (m, 3))
    vert_uv = rng.uniform(0, 1, (nv, 2))
    uv3 = np.empty((m, 3, 2))
    for f, face in enumerate(faces):
        (u0, u1), (v0, v1) = face.surface.domain
        r = face_of == f
        uv3[r] = vert_uv[corners[r]] * [u1 - u0, v1 - v0] + [u0, v0]
    moved = rng.random((m, 3)) < 0.05              # the same vertex at another (u, v) on its face
    uv3[moved] += 1e-3
    n0 = np.array([faces[f].oriented_normals(uv3[k, :1].mean(axis=0)[None])[0] for k, f in enumerate(face_of)])
    side = rng.normal(size=(m, 3))
    side -= np.einsum("ij,ij->i", side, n0)[:, None] * n0
    ang = rng.choice([0.0, 0.5, 1.4, 1.52, 1.5707963, 1.6, 2.0, np.pi], m) + rng.normal(0, 1e-3, m)
    tn = (np.cos(ang)[:, None] * n0 + np.sin(ang)[:, None] * side / np.linalg.norm(side, axis=1)[:, None])
    tn *= rng.uniform(1e-6, 1e3, (m, 1))
    tn[:5] = 0.0                                    # degenerate triangles
    want = _against_normal_reference(faces, face_of, uv3, tn)
    assert 0 < want.sum() < m
    assert _surely_along(faces, face_of, tn).sum() > m // 5           # the shortcut is exercised
    assert np.array_equal(_against_normal(faces, face_of, uv3, tn, corners=corners), want)
    assert np.array_equal(_against_normal(faces, face_of, uv3, tn), want)


def test_normals_are_np_cross_bit_for_bit():
    rng = np.random.default_rng(5)
    V = rng.normal(size=(500, 3)) * 10.0 ** rng.integers(-6, 6, (500, 1))
    T = rng.integers(0, 500, (20000, 3))
    p = V[T]
    want = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    assert np.array_equal(_normals(V, T).view(np.int64), want.view(np.int64))


def _triangulate_polygon_reference(V, poly, corners):
    """stitch._triangulate_polygon as main had it (np.cross, np.linalg.norm, np.unique(axis=0))."""
    import triangle as tr

    poly = [p for k, p in enumerate(poly) if p != poly[k - 1]]
    if len(poly) - 3 <= 0:
        return [tuple(corners)]
    m = len(poly)
    if len(set(poly)) != m:
        return [tuple(corners)]
    P = V[poly]
    o = P.mean(axis=0)
    nrm = np.cross(V[corners[1]] - V[corners[0]], V[corners[2]] - V[corners[0]])
    nrm /= max(np.linalg.norm(nrm), 1e-300)
    e1 = V[corners[1]] - V[corners[0]]
    e1 /= max(np.linalg.norm(e1), 1e-300)
    e2 = np.cross(nrm, e1)
    xy = np.column_stack([(P - o) @ e1, (P - o) @ e2])
    scale = float(np.ptp(xy, axis=0).max()) if m else 0.0
    if scale <= 0 or len(np.unique(np.round(xy / scale, 12), axis=0)) != m:
        return _sequential_fans(poly, corners)
    seg = np.column_stack([np.arange(m), (np.arange(m) + 1) % m])
    try:
        res = tr.triangulate({"vertices": xy, "segments": seg}, "pQ")
    except Exception:   # noqa: BLE001
        return _sequential_fans(poly, corners)
    if len(res["vertices"]) != m or "triangles" not in res:
        return _sequential_fans(poly, corners)
    return [(poly[a], poly[b], poly[c]) for a, b, c in res["triangles"].tolist()
            if len({poly[a], poly[b], poly[c]}) == 3]


def test_triangulate_polygon_is_mains_bit_for_bit():
    """Split triangles with points inserted on their edges (on and off the edge, repeated points,
    a zero-area triangle): the same triangles as main's numpy version."""
    rng = np.random.default_rng(9)
    for trial in range(400):
        c = rng.normal(size=(3, 3)) * 10.0 ** rng.integers(-3, 4) + rng.normal(size=3) * 1e3
        if trial % 50 == 0:
            c[2] = c[0] + 0.5 * (c[1] - c[0])          # degenerate
        pts, poly = [c[0], c[1], c[2]], []
        for k in range(3):
            poly.append(k)
            for t in np.sort(rng.uniform(0, 1, rng.integers(0, 4))):
                p = c[k] + t * (c[(k + 1) % 3] - c[k]) + rng.normal(size=3) * 1e-4 * rng.integers(0, 2)
                pts.append(p if rng.random() > 0.05 else pts[-1])
                poly.append(len(pts) - 1)
        V = np.asarray(pts)
        assert _triangulate_polygon(V, poly, [0, 1, 2]) == _triangulate_polygon_reference(V, poly, [0, 1, 2])


def test_dev_and_against_is_the_two_separate_evaluations():
    """One kernel call per face for both the collapse's deviation and flip tests: the same numbers as
    evaluating the deviation's points with `surface.evaluate` and the flip test's normals per face."""
    from trimsurf.tessellate.seams import _BARY, _dev_and_against

    rng = np.random.default_rng(12)
    faces = [TrimmedFace(_flat_surface(rng, 1, 1, 2, 2), same_sense=False),
             TrimmedFace(_flat_surface(rng, 3, 3, 4, 4, warp=0.4), same_sense=True),
             TrimmedFace(NurbsSurface(2, 1, [0, 0, 0, 1, 1, 1], [0, 0, 1, 1],
                                      np.array([[[1, 0, 0], [1, 0, 2]], [[1, 1, 0], [1, 1, 2]], [[0, 1, 0], [0, 1, 2]]],
                                               dtype=float), np.array([[1, 1], [0.7071, 0.7071], [1, 1]])))]
    surfaces = [f.surface for f in faces]
    m = 3000
    face_of = rng.integers(0, len(faces), m)
    uv3 = rng.uniform(0, 1, (m, 3, 2))
    for f, face in enumerate(faces):
        (u0, u1), (v0, v1) = face.surface.domain
        uv3[face_of == f] = uv3[face_of == f] * [u1 - u0, v1 - v0] + [u0, v0]
    x3 = np.stack([surfaces[f].evaluate(uv3[k]) for k, f in enumerate(face_of)]) + rng.normal(0, 1e-3, (m, 3, 3))
    tn = rng.normal(size=(m, 3))
    tn[: m // 2] = np.array([faces[f].oriented_normals(uv3[k, :1])[0] for k, f in enumerate(face_of[: m // 2])])
    dev, against = _dev_and_against(surfaces, faces, face_of, uv3, x3, tn)
    pts = np.einsum("bj,rjk->rbk", _BARY, uv3)
    ref = np.einsum("bj,rjk->rbk", _BARY, x3)
    s = np.stack([surfaces[f].evaluate(pts[k]) for k, f in enumerate(face_of)])
    assert np.array_equal(dev, np.linalg.norm(s - ref, axis=2).max(axis=1))
    want = _against_normal_reference(faces, face_of, uv3, tn)
    assert 0 < want.sum() < m
    assert np.array_equal(against, want)


def _near_perpendicular_case(seed=21, m=6000):
    """Faces (flat, warped, rational; both senses) and triangles whose normals are the surface normal at a
    sample point turned by exactly 90 degrees (+- a few ulps: the sign of the dot product is decided by
    the rounding, so by the order of its operations), at other angles, degenerate, with corners shared
    by several triangles at equal and at slightly different (u, v) (a periodic seam), and +-0.0 parameters."""
    rng = np.random.default_rng(seed)
    rat = NurbsSurface(2, 1, [0, 0, 0, 1, 1, 1], [0, 0, 1, 1],
                       np.array([[[1, 0, 0], [1, 0, 2]], [[1, 1, 0], [1, 1, 2]], [[0, 1, 0], [0, 1, 2]]], dtype=float),
                       np.array([[1, 1], [0.7071, 0.7071], [1, 1]]))
    sym = NurbsSurface(1, 1, [-1, -1, 1, 1], [-1, -1, 1, 1],
                       np.array([[[-1, -1, 0.3], [-1, 1, -0.2]], [[1, -1, 0.1], [1, 1, 0.4]]], dtype=float))
    faces = [TrimmedFace(_flat_surface(rng, 1, 1, 2, 2), same_sense=True),
             TrimmedFace(_flat_surface(rng, 3, 3, 4, 4, warp=0.4), same_sense=False),
             TrimmedFace(rat, same_sense=True), TrimmedFace(sym, same_sense=False),
             TrimmedFace(_flat_surface(rng, 2, 2, 3, 3, warp=1.0), same_sense=True)]
    nv = 400
    face_of = rng.integers(0, len(faces), m)
    corners = rng.integers(0, nv, (m, 3))
    vert_uv = rng.uniform(0, 1, (nv, 2))
    uv3 = np.empty((m, 3, 2))
    for f, face in enumerate(faces):
        (u0, u1), (v0, v1) = face.surface.domain
        r = face_of == f
        uv3[r] = vert_uv[corners[r]] * [u1 - u0, v1 - v0] + [u0, v0]
    zero = (face_of == 3) & (rng.random(m) < 0.2)              # +-0.0 parameters on the symmetric face
    uv3[zero, 0, :] = rng.choice([0.0, -0.0], (int(zero.sum()), 2))
    moved = rng.random((m, 3)) < 0.05
    uv3[moved] += 1e-3
    b = rng.integers(0, 4, m)                   # the sample point whose normal the triangle's is turned from
    bary = np.array([[1 / 3, 1 / 3, 1 / 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    pts = np.einsum("bj,rjk->rbk", bary, uv3)[np.arange(m), b]
    n = np.array([faces[f].oriented_normals(pts[k][None])[0] for k, f in enumerate(face_of)])
    side = np.cross(n, rng.normal(size=(m, 3)))
    tn = side * 10.0 ** rng.integers(-4, 4, (m, 1))             # perpendicular (to rounding)
    other = rng.random(m) < 0.3
    tn[other] = n[other] * rng.choice([-1.0, 1.0], (int(other.sum()), 1)) + 0.3 * rng.normal(size=(int(other.sum()), 3))
    tn[:7] = 0.0
    return faces, face_of, uv3, tn, corners


def test_against_kernel_is_the_numpy_path_bit_for_bit():
    """The compiled flip test (`_against_kernel`, which `_against_normal` runs on NURBS faces) flags exactly
    the triangles of the numpy passes it replaces and of the faces' public normals, with and without
    the per-vertex corner evaluation, on grazing triangles whose verdict is the rounding's."""
    from trimsurf.tessellate.seams import _against_normal_numpy

    faces, face_of, uv3, tn, corners = _near_perpendicular_case()
    want = _against_normal_reference(faces, face_of, uv3, tn)
    assert 0.1 * len(want) < want.sum() < 0.9 * len(want)
    # the rounding decides many: the dot products summed in another order flag other triangles
    bary = np.array([[1 / 3, 1 / 3, 1 / 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    pts = np.einsum("bj,rjk->rbk", bary, uv3)
    ns = np.stack([faces[f].oriented_normals(pts[k]) for k, f in enumerate(face_of)])
    with np.errstate(invalid="ignore"):
        dot = (ns[..., 0] * tn[:, None, 0] + ns[..., 1] * tn[:, None, 1]) + ns[..., 2] * tn[:, None, 2]
        other = np.any(np.isfinite(dot) & (np.linalg.norm(ns, axis=2) > 0.5) & ~(dot > 0), axis=1)
    assert np.count_nonzero(other != want) > 20
    assert np.array_equal(_against_normal_numpy(faces, face_of, uv3, tn, corners=corners), want)
    assert np.array_equal(_against_normal(faces, face_of, uv3, tn, corners=corners), want)
    assert np.array_equal(_against_normal(faces, face_of, uv3, tn), want)
    # a non-centroid sample set (the stitch's): the same through both paths
    cen = np.array([[1 / 3, 1 / 3, 1 / 3]])
    assert np.array_equal(_against_normal(faces, face_of, uv3, tn, bary=cen),
                          _against_normal_numpy(faces, face_of, uv3, tn, bary=cen))


def test_against_kernel_is_taken_and_falls_back_on_bad_parameters():
    """The kernel answers for NURBS faces with finite parameters; a non-finite sample point of a triangle
    not surely along sends the whole call to the numpy path (the faces' own methods), as before."""
    from trimsurf.tessellate import seams as seams_mod

    faces, face_of, uv3, tn, corners = _near_perpendicular_case(seed=4, m=300)
    axis, flat = seams_mod._face_cones(faces)
    args = (face_of.astype(np.int64), uv3, tn, corners.astype(np.int64), np.bool_(True), seams_mod._ORIENT_BARY,
            *seams_mod._packed(faces)[0], seams_mod._same_sense(faces), axis, flat)
    res, ok = seams_mod._against_kernel(*args)
    assert ok and np.array_equal(res, _against_normal_reference(faces, face_of, uv3, tn))
    bad = uv3.copy()
    k = int(np.flatnonzero(face_of == 1)[0])            # a warped face: never surely along
    bad[k, 1, 0] = np.nan
    res, ok = seams_mod._against_kernel(*((args[0], bad) + args[2:]))
    assert not ok
    from trimsurf.errors import GeometryError

    with pytest.raises(GeometryError, match="NaN"):             # the public method's error, as before
        seams_mod._against_normal_numpy(faces, face_of, bad, tn, corners=corners)
    with pytest.raises(GeometryError, match="NaN"):
        _against_normal(faces, face_of, bad, tn, corners=corners)
    tn_ok = tn.copy()                   # a non-finite point of a triangle surely along is never evaluated
    flat_rows = np.flatnonzero(face_of == 0)
    tn_ok[flat_rows] = axis[0] * 2.0
    bad2 = uv3.copy()
    bad2[flat_rows[0], 0, 1] = np.inf
    res, ok = seams_mod._against_kernel(*((args[0], bad2, tn_ok) + args[3:]))
    assert ok and np.array_equal(res, seams_mod._against_normal_numpy(faces, face_of, bad2, tn_ok, corners=corners))


def test_dev_against_kernel_is_the_numpy_path_bit_for_bit():
    """The compiled deviation and flip test of the collapses (`_dev_against_kernel`) gives the numpy
    passes' deviations bit for bit (NaN where they have it) and their verdicts on grazing triangles; a
    non-finite parameter sends the call to the numpy path."""
    from trimsurf.tessellate import seams as seams_mod

    faces, face_of, uv3, tn, _ = _near_perpendicular_case(seed=8, m=4000)
    surfaces = [f.surface for f in faces]
    rng = np.random.default_rng(1)
    x3 = np.stack([surfaces[f].evaluate(np.clip(uv3[k], *np.transpose(surfaces[f].domain)))
                   for k, f in enumerate(face_of)]) + rng.normal(0, 1e-3, (len(face_of), 3, 3))
    x3[5, 1, 2] = np.nan                                        # a NaN deviation
    dev, against = seams_mod._dev_and_against(surfaces, faces, face_of, uv3, x3, tn)
    ref_dev, ref_against = seams_mod._dev_and_against_numpy(surfaces, faces, face_of, uv3, x3, tn)
    assert np.isnan(dev[5]) and np.count_nonzero(np.isnan(dev)) == 1
    assert np.array_equal(dev.view(np.int64), ref_dev.view(np.int64))
    assert np.array_equal(against, ref_against)
    assert np.array_equal(against, _against_normal_reference(faces, face_of, uv3, tn))
    assert 0 < against.sum() < len(against)
    axis, flat = seams_mod._face_cones(faces)
    args = (face_of.astype(np.int64), uv3, x3, tn, seams_mod._NO_CORNERS, np.bool_(False), seams_mod._BARY,
            seams_mod._ORIENT_BARY, *seams_mod._packed(faces)[0], seams_mod._same_sense(faces), axis, flat)
    assert seams_mod._dev_against_kernel(*args)[2]
    bad = uv3.copy()
    bad[0, 0, 0] = np.inf
    assert not seams_mod._dev_against_kernel(*((args[0], bad) + args[2:]))[2]


def test_grouped_order_is_a_stable_argsort():
    """`seams._grouped_order` (the counting sort of the flip and deviation kernel) groups like numpy's stable
    argsort, also with empty groups and a prefix n shorter than the keys."""
    from trimsurf.tessellate.seams import _grouped_order

    rng = np.random.default_rng(5)
    for n_keys, size in ((1, 10), (7, 500), (40, 30)):
        key = rng.integers(0, n_keys, size)
        for n in (size, size // 2, 0):
            got = _grouped_order(key, n, n_keys)
            assert np.array_equal(got, np.argsort(key[:n], kind="stable"))

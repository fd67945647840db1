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

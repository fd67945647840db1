"""The reconstructed surface: patch set, evaluation, continuity figures, curvature, files."""

from __future__ import annotations

import json
from functools import lru_cache
from dataclasses import dataclass, field

import numpy as np

from ..errors import FileFormatError, InputError
from ..geom import bezier_triangle_derivatives, bezier_triangle_points, triangle_indices
from ..model import BezierTriangleSurface, TriMesh
from ..quality import weld_vertices
from ._hermite import bernstein
from .fill import FacetPatches

__all__ = ["PatchSet", "grid_bary", "save_patches", "load_patches", "g1_continuity"]


def grid_bary(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Barycentric grid of n subdivisions per side and its triangles.

    Returns
    -------
    bary : ((n+1)(n+2)/2, 3) float64
        Rows (a, b, c)/n ordered by a descending, then b descending.
    triangles : (n^2, 3) int64
        Counter-clockwise in the (b, c) plane, i.e. oriented like (e1, e2, e3).
    """
    pts = [(a, b) for a in range(n, -1, -1) for b in range(n - a, -1, -1)]
    index = {p: q for q, p in enumerate(pts)}
    bary = np.array([(a, b, n - a - b) for a, b in pts], float) / max(n, 1)
    tris = []
    for a, b in pts:
        c = n - a - b
        if a >= 1:  # "upward" triangle at (a, b, c): corners (a, b, c) -> (a-1, b+1, c) -> (a-1, b, c+1)
            tris.append([index[(a, b)], index[(a - 1, b + 1)], index[(a - 1, b)]])
        if a >= 1 and b >= 1 and c >= 0 and a - 1 >= 0:
            pass
    for a, b in pts:  # "downward" triangles: (a, b, c), (a-1, b, c+1), (a, b-1, c+1)
        c = n - a - b
        if a >= 1 and b >= 1:
            tris.append([index[(a, b)], index[(a - 1, b)], index[(a, b - 1)]])
    return bary, np.array(tris, dtype=np.int64).reshape(-1, 3)


@dataclass(frozen=True, eq=False)
class PatchSet:
    """Triangular Bézier patches of one degree over the facets of a mesh.

    Attributes
    ----------
    degree : int
    control_points : (P, (n+1)(n+2)/2, 3) float64
        Ordered as `trimsurf.geom.triangle_indices`.
    facet : (P,) int64
        Mesh facet of each patch.
    sub : (P,) int64
        -1: single patch (corners of the facet at e1, e2, e3); k: split patch over
        (corner k, corner k + 1, centroid).
    mesh_vertices, mesh_triangles : arrays
        The input mesh.
    """

    degree: int
    control_points: np.ndarray
    facet: np.ndarray
    sub: np.ndarray
    mesh_vertices: np.ndarray
    mesh_triangles: np.ndarray
    meta: dict = field(default_factory=dict)

    @classmethod
    def from_patches(cls, fp: FacetPatches, mesh_vertices, mesh_triangles, meta=None) -> "PatchSet":
        return cls(fp.degree, fp.control_points, fp.facet, fp.sub, np.asarray(mesh_vertices, float),
                   np.asarray(mesh_triangles, np.int64), dict(meta or {}))

    @property
    def n_patches(self) -> int:
        return int(self.control_points.shape[0])

    def as_surface(self) -> BezierTriangleSurface:
        return BezierTriangleSurface(self.degree, self.control_points)

    def evaluate_mesh(self, density: int = 8, *, weld: bool = True) -> TriMesh:
        """The surface sampled on a barycentric grid of `density` subdivisions per patch side."""
        if isinstance(density, bool) or not isinstance(density, (int, np.integer)) or density < 1:
            raise InputError(f"density must be an integer >= 1; got {density!r}")
        bary, tris = grid_bary(int(density))
        pts = bezier_triangle_points(self.control_points, self.degree, bary)      # (P, k, 3)
        P, k = pts.shape[:2]
        T = (tris[None] + (np.arange(P) * k)[:, None, None]).reshape(-1, 3)
        mesh = TriMesh(pts.reshape(-1, 3), T, face_id=np.repeat(self.facet, len(tris)))
        if not weld:
            return mesh
        diag = float(np.linalg.norm(np.ptp(self.mesh_vertices, axis=0)))
        return weld_vertices(mesh, 1e-9 * max(diag, 1e-300)).mesh

    def gaussian_curvature(self, bary) -> np.ndarray:
        """Gaussian curvature K = (LN - M^2) / (EG - F^2) of every patch at `bary`: (P, k)."""
        D = bezier_triangle_derivatives(self.control_points, self.degree, bary, n_derivs=2)
        xs, xt = D[1, 0], D[0, 1]
        nrm = np.cross(xs, xt)
        a2 = np.einsum("...i,...i->...", nrm, nrm)
        n = nrm / np.sqrt(np.where(a2 > 0, a2, 1.0))[..., None]
        L = np.einsum("...i,...i->...", D[2, 0], n)
        M = np.einsum("...i,...i->...", D[1, 1], n)
        N = np.einsum("...i,...i->...", D[0, 2], n)
        return (L * N - M * M) / np.where(a2 > 0, a2, np.inf)

    def curvature_mesh(self, density: int = 8, *, weld: bool = True) -> tuple[TriMesh, np.ndarray]:
        """Evaluated mesh and the exact Gaussian curvature of the patches at its vertices.

        With `weld`, coincident vertices of neighbouring patches are merged and their
        curvatures averaged (G1 surfaces may jump in curvature across patch boundaries).
        """
        bary, _ = grid_bary(int(density))
        mesh = self.evaluate_mesh(density, weld=False)
        K = self.gaussian_curvature(bary).reshape(-1)
        if not weld:
            return mesh, K
        diag = float(np.linalg.norm(np.ptp(self.mesh_vertices, axis=0)))
        w = weld_vertices(mesh, 1e-9 * max(diag, 1e-300))
        n = w.mesh.n_vertices
        Kw = np.bincount(w.vertex_map, weights=K, minlength=n) / np.bincount(w.vertex_map, minlength=n)
        return w.mesh, Kw


@lru_cache(maxsize=32)
def _side_rows(n: int, a: int, b: int, c: int, depth: int = 2) -> tuple[np.ndarray, ...]:
    """Positions of the control rows parallel to side a -> b: row r (r = 0 .. depth-1) has
    n + 1 - r points and lies r steps towards corner c."""
    pos = {tuple(int(x) for x in r): p for p, r in enumerate(triangle_indices(n))}
    rows = []
    for r in range(min(depth, n + 1)):
        row = []
        for m in range(n + 1 - r):
            cnt = [0, 0, 0]
            cnt[a], cnt[b], cnt[c] = n - r - m, m, r
            row.append(pos[tuple(cnt)])
        rows.append(np.array(row))
    return tuple(rows)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product over the last axis (3), componentwise (faster than np.cross on big arrays)."""
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


def _curve_eval(B: np.ndarray, c: np.ndarray) -> np.ndarray:
    """sum_m B[t, m] c[p, m, d] -> (P, t, d) as one matrix product."""
    P, m, d = c.shape
    out = B @ c.transpose(1, 0, 2).reshape(m, P * d)
    return out.reshape(len(B), P, d).transpose(1, 0, 2)


@lru_cache(maxsize=64)
def _side_operator(n: int, t_key: tuple, curvature: bool) -> np.ndarray:
    """Linear map from the stacked control rows along a side (row 0: n + 1 points, row 1: n,
    row 2: n - 1 with `curvature`) to the point, X_t, X_s (and X_tt, X_ts, X_ss) at the t."""
    t = np.array(t_key)
    n0, n1, n2 = n + 1, n, (n - 1 if curvature else 0)
    blocks = []
    Bn, Bm = bernstein(n, t), bernstein(n - 1, t)
    k = len(t)

    def block(parts):
        out = np.zeros((k, n0 + n1 + n2))
        for off, mat in parts:
            out[:, off:off + mat.shape[1]] += mat
        return out

    D0 = np.eye(n0)[1:] - np.eye(n0)[:-1]                       # (n, n+1) first differences of row 0
    blocks.append(block([(0, Bn)]))
    blocks.append(block([(0, n * Bm @ D0)]))                    # X_t
    blocks.append(block([(n0, n * Bm), (0, -n * Bm @ np.eye(n0)[:-1])]))   # X_s = n sum B (r1 - r0[:-1])
    if curvature:
        Bk = bernstein(n - 2, t) if n >= 2 else np.zeros((k, 0))
        c = n * (n - 1)
        E0, E1 = np.eye(n0), np.eye(n1)
        blocks.append(block([(0, c * Bk @ (E0[2:] - 2 * E0[1:-1] + E0[:-2]))]))                       # X_tt
        blocks.append(block([(n0, c * Bk @ (E1[1:] - E1[:-1])), (0, -c * Bk @ (E0[1:-1] - E0[:-2]))]))  # X_ts
        blocks.append(block([(n0 + n1, c * Bk), (n0, -2 * c * Bk @ E1[:-1]), (0, c * Bk @ E0[:-2])]))   # X_ss
    W = np.concatenate(blocks, axis=0)
    W.setflags(write=False)
    return W


def _side_frame(cp: np.ndarray, n: int, abc: tuple[int, int, int], t: np.ndarray, pid=None,
                curvature: bool = False):
    """Points and unit normals along side a -> b of patches cp (P, N, 3) at parameters t.

    The normal is (d/dt along the side) x (derivative towards corner c), negated when
    (a, b, c) is an odd permutation, so it agrees with the patch orientation. With `pid`,
    only those patches (gathering just the rows needed). With `curvature`, also the
    normal curvature in the tangent direction perpendicular to the side and the mean
    curvature (both signed with the oriented normal), from the exact second derivatives
    (three control rows). One matrix product for all quantities.
    """
    want = bool(curvature)
    curvature = want and n >= 2
    rows = np.concatenate(_side_rows(n, *abc, depth=3 if curvature else 2))
    R = cp[:, rows] if pid is None else cp[pid[:, None], rows[None, :]]      # (P, r, 3)
    W = _side_operator(n, tuple(float(x) for x in t), curvature)
    k = len(t)
    vals = _curve_eval(W, R)                                                  # (P, q k, 3)
    pts, xt, xs = vals[:, :k], vals[:, k:2 * k], vals[:, 2 * k:3 * k]
    nrm = _cross(xt, xs)
    if abc not in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
        nrm = -nrm
    nrm = nrm / np.linalg.norm(nrm, axis=-1, keepdims=True)
    if not curvature:
        if want:
            z = np.zeros(pts.shape[:2])
            return pts, nrm, z, z
        return pts, nrm
    xtt, xts, xss = vals[:, 3 * k:4 * k], vals[:, 4 * k:5 * k], vals[:, 5 * k:]
    dot = lambda a, b: np.einsum("...i,...i->...", a, b)   # noqa: E731
    E_, F_, G_ = dot(xt, xt), dot(xt, xs), dot(xs, xs)
    L_, M_, N_ = dot(xtt, nrm), dot(xts, nrm), dot(xss, nrm)
    det = np.maximum(E_ * G_ - F_ * F_, 1e-300)
    H = (E_ * N_ - 2 * F_ * M_ + G_ * L_) / (2 * det)
    # unit direction w = (Xs - F/E Xt) / |.|, perpendicular to the side in the tangent plane
    al = -F_ / np.maximum(E_, 1e-300)
    kw = (L_ * al * al + 2 * M_ * al + N_) / np.maximum(det / np.maximum(E_, 1e-300), 1e-300)
    return pts, nrm, kw, H


def _side_samples(ps: PatchSet, facets: np.ndarray, sides: np.ndarray, t: np.ndarray, curvature: bool = False):
    """Points and unit normals of the patches touching facet side (f, k) at side parameter t.

    Returns (len(facets), len(t), 3) points and normals (and with `curvature` the cross
    normal curvature and the mean curvature, (len(facets), len(t)) each); t runs from
    corner k to corner k+1.
    """
    n_pts = np.empty((len(facets), len(t), 3))
    n_nrm = np.empty_like(n_pts)
    kw = np.zeros((len(facets), len(t)))
    hm = np.zeros_like(kw)
    single = ps.sub < 0
    lookup_single = np.full(ps.mesh_triangles.shape[0], -1)
    lookup_single[ps.facet[single]] = np.flatnonzero(single)
    lookup_split = np.full((ps.mesh_triangles.shape[0], 3), -1)
    lookup_split[ps.facet[~single], ps.sub[~single]] = np.flatnonzero(~single)
    for k in range(3):
        for kind in ("single", "split"):
            sel = np.flatnonzero(sides == k)
            pid = lookup_single[facets[sel]] if kind == "single" else lookup_split[facets[sel], k]
            ok = pid >= 0
            sel, pid = sel[ok], pid[ok]
            if not len(sel):
                continue
            abc = (k, (k + 1) % 3, (k + 2) % 3) if kind == "single" else (0, 1, 2)
            out = _side_frame(ps.control_points, ps.degree, abc, t, pid, curvature)
            n_pts[sel], n_nrm[sel] = out[0], out[1]
            if curvature:
                kw[sel], hm[sel] = out[2], out[3]
    if curvature:
        return n_pts, n_nrm, kw, hm
    return n_pts, n_nrm


def _angle_deg(a, b):
    """Angle between vectors, accurate near 0 (atan2 of |a x b| and a . b)."""
    return np.degrees(np.arctan2(np.linalg.norm(_cross(a, b), axis=-1), np.einsum("...i,...i->...", a, b)))


def g1_continuity(ps: PatchSet, *, n_samples: int = 17, interior: bool = True, curvature: bool = False) -> dict:
    """G0 gap, G1 normal angle and (optionally) curvature jumps across every patch edge.

    Samples each shared network curve, and the inner curves of split facets, at
    `n_samples` parameters (ends excluded when `interior`, where all patches meet at a
    vertex and the normal is the vertex normal). Normals come from the first two control
    rows along the curve (exact derivatives), curvatures from the first three. All
    figures are maxima over these samples, not bounds between them.

    Returns
    -------
    dict with ``g0_gap`` (max distance), ``g1_angle_max_deg``, ``g1_angle_rms_deg`` (across
    the mesh edges), ``g1_angle_inner_max_deg`` (across the inner curves of split facets),
    ``edge_angles_deg`` (per shared edge maximum), ``n_samples``; with `curvature` also
    ``curvature_jump_max`` (largest difference of the two patches' normal curvatures in
    the surface direction perpendicular to the edge, 1/length), ``mean_curvature_jump_max``
    (of the mean curvatures), ``curvature_on_edges_max`` (largest |normal curvature| across
    edges, for scale), each over all patch edges, and ``edge_curvature_jumps`` (per shared
    mesh edge maximum).
    """
    T = ps.mesh_triangles
    F = len(T)
    a, b = T, np.roll(T, -1, axis=1)
    key = (np.minimum(a, b) * (T.max() + 1) + np.maximum(a, b)).ravel()
    order = np.argsort(key, kind="stable")
    ks = key[order]
    same = np.flatnonzero(ks[1:] == ks[:-1])
    h1, h2 = order[same], order[same + 1]
    f1, s1, f2, s2 = h1 // 3, h1 % 3, h2 // 3, h2 % 3
    t = np.linspace(0, 1, n_samples + 2)[1:-1] if interior else np.linspace(0, 1, n_samples)
    o1 = _side_samples(ps, f1, s1, t, curvature)
    o2 = _side_samples(ps, f2, s2, t[::-1], curvature)
    p1, n1, p2, n2 = o1[0], o1[1], o2[0], o2[1]
    gap = np.linalg.norm(p1 - p2, axis=2)
    ang = _angle_deg(n1, n2)
    out = {"g0_gap": float(gap.max()) if gap.size else 0.0,
           "g1_angle_max_deg": float(ang.max()) if ang.size else 0.0,
           "g1_angle_rms_deg": float(np.sqrt(np.mean(ang ** 2))) if ang.size else 0.0,
           "edge_angles_deg": ang.max(axis=1) if ang.size else np.zeros(0), "n_samples": int(n_samples)}
    jumps = {"k": [0.0], "h": [0.0], "abs": [0.0]}
    if curvature:
        dk = np.abs(o1[2] - o2[2])
        out["edge_curvature_jumps"] = dk.max(axis=1) if dk.size else np.zeros(0)
        if dk.size:
            jumps["k"].append(float(dk.max()))
            jumps["h"].append(float(np.abs(o1[3] - o2[3]).max()))
            jumps["abs"].append(float(max(np.abs(o1[2]).max(), np.abs(o2[2]).max())))
    split = ps.sub >= 0
    inner = 0.0
    if split.any():
        pid = np.full((F, 3), -1)
        pid[ps.facet[split], ps.sub[split]] = np.flatnonzero(split)
        fs = np.flatnonzero((pid >= 0).all(axis=1))
        for k in range(len(fs) and 3):
            # inner curve k (V_k -> Z): sub k side (0 -> 2), sub k-1 side (1 -> 2)
            oa = _side_frame(ps.control_points, ps.degree, (0, 2, 1), t, pid[fs, k], curvature)
            ob = _side_frame(ps.control_points, ps.degree, (1, 2, 0), t, pid[fs, (k - 1) % 3], curvature)
            inner = max(inner, float(_angle_deg(oa[1], ob[1]).max()))
            out["g0_gap"] = max(out["g0_gap"], float(np.linalg.norm(oa[0] - ob[0], axis=2).max()))
            if curvature:
                jumps["k"].append(float(np.abs(oa[2] - ob[2]).max()))
                jumps["h"].append(float(np.abs(oa[3] - ob[3]).max()))
                jumps["abs"].append(float(max(np.abs(oa[2]).max(), np.abs(ob[2]).max())))
    out["g1_angle_inner_max_deg"] = inner
    if curvature:
        out["curvature_jump_max"] = max(jumps["k"])
        out["mean_curvature_jump_max"] = max(jumps["h"])
        out["curvature_on_edges_max"] = max(jumps["abs"])
    return out


_FORMAT = "trimsurf-patches-1"


def save_patches(ps: PatchSet, path) -> None:
    """Write a patch set as ``.npz`` (arrays) or ``.json`` (nested lists), atomically."""
    from pathlib import Path

    from ..io._atomic import atomic_path

    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".npz", ".json"):
        raise FileFormatError(f"{path}: patch files must end in .npz or .json; got {suffix!r}")
    with atomic_path(path) as tmp:
        if suffix == ".npz":
            with open(tmp, "wb") as fh:
                np.savez_compressed(fh, format=np.array(_FORMAT), degree=np.array(ps.degree),
                                    control_points=ps.control_points, facet=ps.facet, sub=ps.sub,
                                    mesh_vertices=ps.mesh_vertices, mesh_triangles=ps.mesh_triangles,
                                    meta=np.array(json.dumps(_jsonable(ps.meta))))
        else:
            doc = {"format": _FORMAT, "degree": ps.degree, "control_points": ps.control_points.tolist(),
                   "facet": ps.facet.tolist(), "sub": ps.sub.tolist(),
                   "mesh_vertices": ps.mesh_vertices.tolist(), "mesh_triangles": ps.mesh_triangles.tolist(),
                   "meta": _jsonable(ps.meta)}
            tmp.write_text(json.dumps(doc), encoding="utf-8")


def _jsonable(x):
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, np.generic):
        return x.item()
    return x


def load_patches(path) -> PatchSet:
    """Read a patch set written by `save_patches` (.npz or .json).

    Raises
    ------
    FileFormatError
        Missing, unreadable or malformed file.
    """
    from pathlib import Path

    path = Path(path)
    if not path.is_file():
        raise FileFormatError(f"{path}: no such file")
    try:
        if path.suffix.lower() == ".npz":
            with np.load(path, allow_pickle=False) as z:
                doc = {k: z[k] for k in z.files}
            doc["format"] = str(doc["format"])
            doc["meta"] = json.loads(str(doc.get("meta", "{}")))
        elif path.suffix.lower() == ".json":
            doc = json.loads(path.read_text(encoding="utf-8"))
        else:
            raise FileFormatError(f"{path}: patch files must end in .npz or .json")
        if doc.get("format") != _FORMAT:
            raise FileFormatError(f"{path}: not a trimsurf patch file (format {doc.get('format')!r})")
        degree = int(doc["degree"])
        cp = np.asarray(doc["control_points"], dtype=np.float64)
        if cp.ndim != 3 or cp.shape[1] != (degree + 1) * (degree + 2) // 2 or cp.shape[2] != 3:
            raise FileFormatError(f"{path}: control_points of shape {cp.shape} do not fit degree {degree}")
        return PatchSet(degree, cp, np.asarray(doc["facet"], np.int64), np.asarray(doc["sub"], np.int64),
                        np.asarray(doc["mesh_vertices"], float).reshape(-1, 3),
                        np.asarray(doc["mesh_triangles"], np.int64).reshape(-1, 3), doc.get("meta") or {})
    except FileFormatError:
        raise
    except (KeyError, ValueError, TypeError, OSError) as exc:
        raise FileFormatError(f"{path}: malformed patch file ({exc})") from None

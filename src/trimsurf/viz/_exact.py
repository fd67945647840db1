"""Reference geometry for pictures: a mesh refined densely with exact points, normals and curvatures.

The "exact" zebra of a CAD face is drawn on the tessellation subdivided
uniformly in (u, v) (each triangle split 4^level times), with every new
vertex placed on the surface and given the surface's exact normal. With
sub-pixel triangles the linear interpolation no longer shows, so the stripes
are those of the surface itself, not of the mesh.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from ..errors import InputError
from ..model import Shell, TriMesh, TrimmedFace
from ._curvature import Curvatures, surface_curvatures

__all__ = ["ExactSurface", "subdivide", "refine_exact", "refinement_level", "unshare_faces"]

#: an exact surface given as a function: points (n, 3) near it -> (points on it, unit normals)
ExactSurface = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]


def refinement_level(n_triangles: int, target: int = 250_000, max_level: int = 6) -> int:
    """Fewest 1-to-4 splits that bring `n_triangles` to at least `target` (at most `max_level`).

    A mesh that already has `target` triangles is not split: it only gets
    exact points and normals at its vertices.

    >>> refinement_level(80), refinement_level(10_000), refinement_level(200_000), refinement_level(300_000)
    (6, 3, 1, 0)
    """
    level = int(np.ceil(np.log(max(target, 1) / max(n_triangles, 1)) / np.log(4.0)))
    return int(np.clip(level, 0, max_level))


def subdivide(mesh: TriMesh, level: int) -> TriMesh:
    """Split every triangle into 4 by its edge midpoints, `level` times (uv and face_id carried along).

    >>> m = TriMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], uv=[[0, 0], [1, 0], [0, 1]])
    >>> s = subdivide(m, 2)
    >>> s.n_triangles, s.n_vertices
    (16, 15)
    """
    V, T, uv, fid = mesh.vertices, mesh.triangles, mesh.uv, mesh.face_id
    for _ in range(int(level)):
        n = len(V)
        he = np.stack([T, np.roll(T, -1, axis=1)], axis=2).reshape(-1, 2)
        key = np.minimum(he[:, 0], he[:, 1]) * n + np.maximum(he[:, 0], he[:, 1])
        keys, inv = np.unique(key, return_inverse=True)
        a, b = keys // n, keys % n
        V = np.concatenate([V, 0.5 * (V[a] + V[b])])
        if uv is not None:
            uv = np.concatenate([uv, 0.5 * (uv[a] + uv[b])])
        mid = (n + inv.ravel()).reshape(-1, 3)  # mid[:, c]: midpoint of edge corner c -> c+1
        t0, t1, t2 = T[:, 0], T[:, 1], T[:, 2]
        m01, m12, m20 = mid[:, 0], mid[:, 1], mid[:, 2]
        T = np.concatenate([np.stack([t0, m01, m20], 1), np.stack([m01, t1, m12], 1),
                            np.stack([m20, m12, t2], 1), np.stack([m01, m12, m20], 1)])
        if fid is not None:
            fid = np.tile(fid, 4)
    return TriMesh(V, T, uv=uv, face_id=fid)


def _split_by_face(mesh: TriMesh) -> list[tuple[int, TriMesh]]:
    """One mesh per face id, vertices unshared across faces (so creases stay creases)."""
    if mesh.face_id is None:
        return [(0, mesh)]
    out = []
    for f in np.unique(mesh.face_id):
        T = mesh.triangles[mesh.face_id == f]
        used, Tl = np.unique(T, return_inverse=True)
        uv = mesh.uv[used] if mesh.uv is not None else None
        out.append((int(f), TriMesh(mesh.vertices[used], Tl.reshape(-1, 3), uv=uv,
                                    face_id=np.full(len(T), f, dtype=np.int64))))
    return out


#: a seam edge between two faces is smooth (G1 join, normals shared) when its dihedral angle is at most this
#: multiple of the largest dihedral angle of the faces' own edges around its two ends (see `unshare_faces`)
SEAM_CREASE_RATIO = 2.0
#: a seam edge with a dihedral angle above this is a crease whatever the mesh around it (degrees)
SEAM_CREASE_MAX_DEG = 30.0


def _seam_edges(mesh: TriMesh) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Seam edges (two triangles of different faces): (ends a, ends b, triangle A, triangle B, smooth?)."""
    T, n = mesh.triangles, mesh.n_vertices
    tn = mesh.triangle_normals()
    tn = tn / np.maximum(np.linalg.norm(tn, axis=1, keepdims=True), 1e-300)
    he = np.stack([T, np.roll(T, -1, axis=1)], axis=2).reshape(-1, 2)
    he.sort(axis=1)
    key = he[:, 0] * n + he[:, 1]
    keys, inv, cnt = np.unique(key, return_inverse=True, return_counts=True)
    order = np.argsort(inv, kind="stable")
    starts = np.r_[0, np.cumsum(cnt)[:-1]]
    tri = np.arange(len(T)).repeat(3)
    ta, tb = tri[order[starts]], tri[order[starts + cnt - 1]]  # the two triangles of a manifold edge
    manifold = cnt == 2
    ang = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", tn[ta], tn[tb]), -1.0, 1.0)))
    seam = manifold & (mesh.face_id[ta] != mesh.face_id[tb])
    inner = manifold & ~seam
    a, b = keys // n, keys % n
    # largest dihedral angle of the faces' own edges on the triangles around each vertex (their far edges
    # too: on a mesh swept in strips the bend sits on the edges one step away from the seam)
    own = np.where(inner, ang, 0.0)[inv].reshape(-1, 3).max(axis=1)
    ring = np.zeros(n)
    np.maximum.at(ring, T.ravel(), np.repeat(own, 3))
    local = np.maximum(ring[a], ring[b])
    smooth = (ang <= SEAM_CREASE_RATIO * local) & (ang <= SEAM_CREASE_MAX_DEG)
    s = np.flatnonzero(seam)
    return a[s], b[s], ta[s], tb[s], smooth[s]


def seam_exact_angles(mesh: TriMesh, faces_uv: TriMesh, exact: Shell) -> tuple[np.ndarray, np.ndarray]:
    """Exact normals' angle across each seam edge of `mesh` (as `_seam_edges` lists them), and its verdict.

    `mesh` is the joined mesh (seam vertices shared, ``face_id``); `faces_uv` the same faces unshared with
    each vertex's (u, v) on its own face (as ``trimsurf view`` prepares a tessellation), from which
    `refine_exact` gives the two faces' exact normals at the edge's ends.

    Returns
    -------
    ends_deg : (2, k) float64
        Angle (degrees) between the two faces' exact normals at end a and at end b; NaN where an end is
        not found on a face.
    smooth : (k,) bool
        Whether `unshare_faces` shares the edge (shades it as a smooth join).
    """
    from scipy.spatial import cKDTree

    fine, normals, _ = refine_exact(faces_uv, exact, level=0)  # exact normals, per face
    vface = np.full(fine.n_vertices, -1)
    vface[fine.triangles.ravel()] = np.repeat(fine.face_id, 3)
    tol = 1e-4 * float(np.linalg.norm(np.ptp(mesh.vertices, axis=0)))
    tree = cKDTree(fine.vertices)
    a, b, ta, tb, smooth = _seam_edges(mesh)

    def normal(v, f):
        d, idx = tree.query(mesh.vertices[v], k=16, distance_upper_bound=tol)
        idx = np.minimum(idx, fine.n_vertices - 1)
        ok = (vface[idx] == f[:, None]) & (d < tol)
        j = np.argmax(ok, axis=1)
        r = np.arange(len(v))
        return np.where(ok[r, j][:, None], normals[idx[r, j]], np.nan)

    ends = [np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", normal(v, mesh.face_id[ta]),
                                                   normal(v, mesh.face_id[tb])), -1, 1))) for v in (a, b)]
    return np.array(ends), smooth


def unshare_faces(mesh: TriMesh) -> TriMesh:
    """The mesh with its vertices duplicated along creases between CAD faces (``face_id``), so normals do not blend there.

    A CAD viewer shades each face with its own normals: averaging vertex
    normals across a crease between two faces smears the crease over the
    neighbouring triangles. Where two faces join smoothly (G1: a fillet and
    the plane it runs into, two patches of a reconstructed surface) the seam
    vertices stay shared, so their normals average over both sides as inside
    a face: one-sided normals there differ by the discretization angle and
    draw a stripe break along the seam that is not in the surface (a false
    alarm in zebra pictures).

    A seam edge is a crease when its dihedral angle exceeds ``SEAM_CREASE_RATIO``
    (2) times the largest dihedral angle of the faces' own edges on the
    triangles around its two ends, or ``SEAM_CREASE_MAX_DEG`` (30 degrees).
    On a G1 join the seam's angle is a discretization angle like theirs:
    measured at most 1.39 times on reconstruct's G1 fills (octahedron,
    boundary_problem, car_panel; g2 single, g1 and g2 split; densities 8 and
    16). Against the exact normals of 7 real CAD files tessellated with the
    defaults (benchmarks/zebra_seams.py): 4484 of 5169 G1 seam edges are
    shared (none before), 69 of 4310 crease edges are, all of at most 30
    degrees where the mesh around them bends as much; the G1 seams still
    split are those whose mesh folds by more than 30 degrees (coarse
    fillets) or more than twice as much as the mesh around them.
    Non-manifold seam edges are creases. Meshes without ``face_id`` (or of
    one face) come back unchanged.

    >>> m = TriMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 1]], [[0, 1, 2], [1, 3, 2]], face_id=[0, 1])
    >>> unshare_faces(m).n_vertices  # a 55 degree crease between two flat faces: split
    6
    >>> flat = TriMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], [[0, 1, 2], [1, 3, 2]], face_id=[0, 1])
    >>> unshare_faces(flat).n_vertices  # a flat (smooth) seam: shared
    4
    """
    if mesh.face_id is None or len(np.unique(mesh.face_id)) < 2:
        return mesh
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    T = mesh.triangles
    F = np.asarray(mesh.face_id, dtype=np.int64)
    F = F - F.min()
    # one node per (vertex, face) corner pair; smooth seam edges join a vertex's nodes of the two faces
    stride = int(F.max()) + 1
    pair_keys, node = np.unique(T.ravel().astype(np.int64) * stride + np.repeat(F, 3), return_inverse=True)
    node = node.ravel()
    a, b, ta, tb, smooth = _seam_edges(mesh)
    a, b, ta, tb = a[smooth], b[smooth], ta[smooth], tb[smooth]

    def find(v, f):
        return np.searchsorted(pair_keys, v * stride + f)

    u = np.concatenate([find(a, F[ta]), find(b, F[ta])])
    w = np.concatenate([find(a, F[tb]), find(b, F[tb])])
    g = coo_matrix((np.ones(len(u)), (u, w)), shape=(len(pair_keys), len(pair_keys)))
    _, comp = connected_components(g, directed=False)
    # each component becomes one vertex (its first node's vertex: all nodes of a component share it)
    rep = np.zeros(comp.max() + 1, dtype=np.int64)
    rep[comp[::-1]] = pair_keys[::-1] // stride
    uv = mesh.uv[rep] if mesh.uv is not None else None
    return TriMesh(mesh.vertices[rep], comp[node].reshape(-1, 3), uv=uv, face_id=np.asarray(mesh.face_id).copy())


def _face_uv(face: TrimmedFace, mesh: TriMesh, uv: np.ndarray | None) -> np.ndarray:
    """(u, v) of the mesh's vertices on `face`: the given ones, else by closest-point projection."""
    s = face.surface
    if uv is not None:
        return uv
    from ..geom.projection import project_to_surface

    return project_to_surface(mesh.vertices, s.degree_u, s.degree_v, s.knots_u, s.knots_v, s.control_points,
                              s.weights).uv


def refine_exact(mesh: TriMesh, exact: Shell | TrimmedFace | ExactSurface, *, level: int | None = None,
                 curvature: bool = False) -> tuple[TriMesh, np.ndarray, Curvatures | None]:
    """Refine `mesh` and put it on the exact surface.

    Parameters
    ----------
    mesh : TriMesh
        A tessellation of `exact`. With a `Shell` of several faces it needs
        ``face_id``; it uses ``uv`` when present (single-face meshes) and
        projects the vertices onto the face's surface otherwise.
    exact : Shell, TrimmedFace or callable
        The true surface. A callable maps points (n, 3) near the surface to
        (points on it, unit outward normals).
    level : int, optional
        Number of 1-to-4 splits (default: the fewest that give 250k triangles, see `refinement_level`).
    curvature : bool
        Also return exact curvatures (CAD faces only; a callable gets None).

    Returns
    -------
    mesh : TriMesh
        The refined mesh on the surface.
    normals : (n, 3) float64
        Exact unit normals at its vertices (outward for CAD faces).
    curvatures : Curvatures or None
    """
    if level is None:
        level = refinement_level(mesh.n_triangles)
    if callable(exact) and not isinstance(exact, (Shell, TrimmedFace)):
        fine = subdivide(mesh, level)
        pts, nrm = exact(fine.vertices)
        pts, nrm = np.asarray(pts, dtype=np.float64), np.asarray(nrm, dtype=np.float64)
        if pts.shape != fine.vertices.shape or nrm.shape != fine.vertices.shape:
            raise InputError(f"exact surface function must return two ({fine.n_vertices}, 3) arrays; "
                             f"got {pts.shape} and {nrm.shape}")
        return TriMesh(pts, fine.triangles, face_id=fine.face_id), nrm, None
    faces = (exact,) if isinstance(exact, TrimmedFace) else tuple(exact.faces)
    if len(faces) > 1 and mesh.face_id is None:
        raise InputError(f"the exact reference of a shell with {len(faces)} faces needs a mesh with face_id")
    parts_V, parts_T, parts_N, parts_F, curv = [], [], [], [], []
    offset = 0
    for f, part in _split_by_face(mesh):
        if not 0 <= f < len(faces):
            raise InputError(f"mesh face_id {f} is not a face of the shell ({len(faces)} faces)")
        if len(faces) == 1:
            f = 0
        face = faces[f]
        uv = _face_uv(face, part, part.uv if (len(faces) == 1 or mesh.face_id is not None) else None)
        fine = subdivide(TriMesh(part.vertices, part.triangles, uv=uv, face_id=part.face_id), level)
        d = face.surface.derivatives(fine.uv, 2 if curvature else 1)
        nrm = np.cross(d[1, 0], d[0, 1])
        nrm /= np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-300)
        if not face.same_sense:
            nrm = -nrm
        parts_V.append(d[0, 0])
        parts_T.append(fine.triangles + offset)
        parts_N.append(nrm)
        parts_F.append(fine.face_id if fine.face_id is not None else np.zeros(fine.n_triangles, np.int64))
        if curvature:
            curv.append(surface_curvatures(d, flip=not face.same_sense))
        offset += fine.n_vertices
    out = TriMesh(np.concatenate(parts_V), np.concatenate(parts_T), face_id=np.concatenate(parts_F))
    c = Curvatures(*(np.concatenate([getattr(x, k) for x in curv]) for k in Curvatures._fields)) if curvature \
        else None
    N = np.concatenate(parts_N)
    bad = ~np.all(np.isfinite(N), axis=1)
    if bad.any():  # singular points (poles): fall back to the mesh normal there
        from ._shading import vertex_normals

        N[bad] = vertex_normals(out)[bad]
    return out, N, c

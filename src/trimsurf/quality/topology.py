"""Topology of a triangle mesh: welding, manifoldness, orientation, components, genus.

References
----------
M. Botsch, L. Kobbelt, M. Pauly, P. Alliez, B. Lévy, *Polygon Mesh
Processing*, AK Peters 2010, Sec. 1.3 (Euler formula V - E + F = 2 - 2g - b
for an orientable 2-manifold component with b boundary loops).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import sparse
from scipy.sparse import csgraph
from scipy.spatial import cKDTree

from ..errors import InputError
from ..model import TriMesh
from ._results import ResultMixin

__all__ = ["weld_vertices", "Welded", "orientation_flips", "boundary_loop_count", "TopologyReport",
           "topology_report"]


@dataclass(frozen=True, eq=False)
class Welded(ResultMixin):
    """A mesh whose vertices closer than a tolerance were merged.

    Attributes
    ----------
    mesh : TriMesh
        Welded mesh; triangles that collapsed (two corners welded) are dropped.
    vertex_map : (n,) int64
        Index in `mesh.vertices` of every input vertex.
    dropped_triangles : (k,) int64
        Input triangles that collapsed.
    n_merged : int
        Input vertices minus output vertices.
    """

    mesh: TriMesh
    vertex_map: np.ndarray
    dropped_triangles: np.ndarray
    n_merged: int

    def as_dict(self, *, arrays: bool = False) -> dict:
        return {"n_vertices": self.mesh.n_vertices, "n_triangles": self.mesh.n_triangles,
                "n_merged": int(self.n_merged), "n_dropped_triangles": int(len(self.dropped_triangles))}


def weld_vertices(mesh: TriMesh, tol: float) -> Welded:
    """Merge vertices closer than `tol` (model units).

    Parameters
    ----------
    mesh : TriMesh
    tol : float
        Distance at or below which two vertices are welded; 0 merges exact duplicates only.

    Returns
    -------
    Welded
        Each cluster keeps the position of its lowest-index vertex; vertices
        keep their order of first appearance; `uv` is dropped when welded
        vertices carried different uv, `face_id` is kept.

    Raises
    ------
    InputError
        `tol` negative or not finite.

    Notes
    -----
    Clusters are the connected components of the "closer than tol" graph, so
    a chain of close vertices welds into one vertex even when its ends are
    farther apart than `tol`; keep `tol` well below the shortest edge.

    Examples
    --------
    >>> m = TriMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 0, 0], [1, 1, 0]], [[0, 1, 2], [3, 4, 2]])
    >>> weld_vertices(m, 1e-9).mesh.triangles.tolist()
    [[0, 1, 2], [1, 3, 2]]
    """
    if not isinstance(mesh, TriMesh):
        raise InputError(f"weld_vertices needs a TriMesh; got {type(mesh).__name__}")
    tol = float(tol)
    if not (np.isfinite(tol) and tol >= 0):
        raise InputError(f"weld tolerance must be a finite number >= 0; got {tol!r}")
    n = mesh.n_vertices
    if tol > 0:
        pairs = cKDTree(mesh.vertices).query_pairs(tol, output_type="ndarray")
    else:
        _, first, inv = np.unique(mesh.vertices, axis=0, return_index=True, return_inverse=True)
        pairs = np.column_stack([np.arange(n), first[inv.ravel()]])
    g = sparse.coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, label = csgraph.connected_components(g, directed=False)
    rep = np.full(label.max() + 1 if n else 0, n, dtype=np.int64)
    np.minimum.at(rep, label, np.arange(n))            # lowest index of each cluster
    keep = np.unique(rep)                              # sorted: order of first appearance
    new_index = np.empty(n, dtype=np.int64)
    new_index[keep] = np.arange(len(keep))
    vertex_map = new_index[rep[label]]
    tris = vertex_map[mesh.triangles]
    bad = (tris[:, 0] == tris[:, 1]) | (tris[:, 1] == tris[:, 2]) | (tris[:, 0] == tris[:, 2])
    uv = None
    if mesh.uv is not None:
        uv = mesh.uv[keep]
        if not np.array_equal(uv[vertex_map], mesh.uv):
            uv = None
    fid = None if mesh.face_id is None else mesh.face_id[~bad]
    out = TriMesh(mesh.vertices[keep], tris[~bad], uv=uv, face_id=fid)
    return Welded(out, vertex_map, np.flatnonzero(bad).astype(np.int64), n - len(keep))


def orientation_flips(mesh: TriMesh) -> tuple[np.ndarray, np.ndarray]:
    """Which triangles to flip for a consistent orientation, and which components cannot be oriented.

    Two triangles on a manifold edge agree when they run the edge in
    opposite directions. Orientability is checked on the doubled graph
    (nodes (t, s), s in {0, 1}; an edge joins (t1, s) and (t2, s xor r) with
    r = 1 when t1, t2 disagree): a component is orientable exactly when
    (t, 0) and (t, 1) fall into different components. In each orientable
    component the smaller of the two classes is flipped.

    Returns
    -------
    flip : (m,) bool
        Triangles to reverse (False in non-orientable components).
    non_orientable : (m,) bool
        Triangles in a component (through manifold edges) that cannot be oriented (Möbius-like).
    """
    m = mesh.n_triangles
    if not m:
        return np.zeros(0, bool), np.zeros(0, bool)
    he = mesh.half_edges()
    inv = mesh.half_edge_edges()
    counts = mesh.edge_triangle_counts()
    manifold = counts[inv] == 2
    h = np.flatnonzero(manifold)
    order = h[np.argsort(inv[h], kind="stable")]
    h1, h2 = order[0::2], order[1::2]
    t1, t2 = h1 // 3, h2 // 3
    r = (he[h1, 0] == he[h2, 0]).astype(np.int64)     # same direction: they disagree
    rows = np.r_[t1, t1 + m]
    cols = np.r_[t2 + m * r, t2 + m * (1 - r)]
    g = sparse.coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(2 * m, 2 * m))
    _, label = csgraph.connected_components(g, directed=False)
    l0, l1 = label[:m], label[m:]
    non_orientable = l0 == l1
    size = np.bincount(l0, minlength=label.max() + 1)  # triangles whose "as is" node lies in each class
    # flip t when its class is the smaller one of its component (ties: the class with the larger label)
    flip = ~non_orientable & ((size[l0] < size[l1]) | ((size[l0] == size[l1]) & (l0 > l1)))
    return flip, non_orientable


def boundary_loop_count(mesh: TriMesh) -> int:
    """Number of boundary loops: connected components of the boundary-edge graph."""
    be = mesh.boundary_edges()
    if not len(be):
        return 0
    used, e = np.unique(be, return_inverse=True)
    e = e.reshape(-1, 2)
    g = sparse.coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(len(used), len(used)))
    return int(csgraph.connected_components(g, directed=False)[0])


@dataclass(frozen=True, eq=False)
class TopologyReport(ResultMixin):
    """Topology figures of a mesh (after optional welding).

    Attributes
    ----------
    n_vertices, n_triangles, n_edges : int
        Of the (welded) mesh; vertices counted only when used by a triangle.
    n_boundary_edges, n_boundary_loops : int
    n_non_manifold_edges, n_non_manifold_vertices : int
    is_watertight : bool
        Every edge has exactly two triangles (after welding).
    n_inconsistent_edges : int
        Manifold edges whose two triangles run it in the same direction.
    is_consistently_oriented : bool
    is_orientable : bool
    n_flipped_triangles : int
        Fewest triangles to reverse for a consistent orientation.
    flipped_triangles : (k,) int64
    n_components : int
        Components of triangles joined through edges.
    euler_characteristic : int
    component_euler : (c,) int64
    component_boundary_loops : (c,) int64
    component_genus : (c,) float64
        (2 - chi - b) / 2 per orientable manifold component, NaN otherwise.
    genus : int or None
        Sum of component genera, None if any is undefined.
    n_welded_vertices, n_degenerate_after_weld : int
    weld_tol : float
    """

    n_vertices: int
    n_triangles: int
    n_edges: int
    n_boundary_edges: int
    n_boundary_loops: int
    n_non_manifold_edges: int
    n_non_manifold_vertices: int
    is_watertight: bool
    n_inconsistent_edges: int
    is_consistently_oriented: bool
    is_orientable: bool
    n_flipped_triangles: int
    flipped_triangles: np.ndarray
    n_components: int
    euler_characteristic: int
    component_euler: np.ndarray
    component_boundary_loops: np.ndarray
    component_genus: np.ndarray
    genus: int | None
    n_welded_vertices: int
    n_degenerate_after_weld: int
    weld_tol: float


def topology_report(mesh: TriMesh, *, weld_tol: float | None = None) -> TopologyReport:
    """Boundary, manifoldness, orientation, components, Euler characteristic and genus of a mesh.

    Parameters
    ----------
    mesh : TriMesh
    weld_tol : float or None
        Weld vertices closer than this first (model units); None or 0 welds
        exact duplicates only (so STL-like soups are analysed as surfaces).

    Returns
    -------
    TopologyReport

    Raises
    ------
    InputError
        Not a TriMesh, or a bad `weld_tol`.

    Examples
    --------
    >>> tet = TriMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])
    >>> r = topology_report(tet)
    >>> r.is_watertight, r.euler_characteristic, r.genus
    (True, 2, 0)
    """
    if not isinstance(mesh, TriMesh):
        raise InputError(f"topology_report needs a TriMesh; got {type(mesh).__name__}")
    welded = weld_vertices(mesh, 0.0 if weld_tol is None else weld_tol)
    w = welded.mesh
    m = w.n_triangles
    edges = w.edges()
    counts = w.edge_triangle_counts()
    flip, non_orientable = orientation_flips(w)
    labels = w.connected_components() if m else np.zeros(0, np.int64)
    n_comp = int(labels.max() + 1) if m else 0
    # per component: V, E, F, boundary loops, manifoldness. V: the distinct (component, vertex) pairs (a
    # vertex where components touch counts in each), as one int64 key each (a 1-D unique, not a row one)
    n_v = max(w.n_vertices, 1)
    pairs = np.unique(np.repeat(labels, 3) * n_v + w.triangles.ravel()) if m else np.zeros(0, np.int64)
    v_c = np.bincount(pairs // n_v, minlength=n_comp)
    f_c = np.bincount(labels, minlength=n_comp)
    vertex_comp = np.zeros(w.n_vertices, dtype=np.int64)
    vertex_comp[w.triangles.ravel()] = np.repeat(labels, 3)
    # an edge's component: that of any of its triangles (all of them are connected through it); not its
    # first vertex's, which may be a vertex where another component touches
    edge_comp = np.zeros(len(edges), dtype=np.int64)
    if m:
        edge_comp[w.half_edge_edges()] = np.repeat(labels, 3)
    e_c = np.bincount(edge_comp, minlength=n_comp)
    chi_c = (v_c - e_c + f_c).astype(np.int64)
    bnd = w.boundary_edges()
    loops_c = np.zeros(n_comp, dtype=np.int64)
    if len(bnd):
        used, e = np.unique(bnd, return_inverse=True)
        e = e.reshape(-1, 2)
        g = sparse.coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(len(used), len(used)))
        n_loops, loop_label = csgraph.connected_components(g, directed=False)
        loop_comp = np.zeros(n_loops, dtype=np.int64)
        loop_comp[loop_label] = vertex_comp[used]
        loops_c = np.bincount(loop_comp, minlength=n_comp)
    nm_edges = edges[counts > 2]
    nm_verts = w.non_manifold_vertices()
    bad_comp = np.zeros(n_comp, dtype=bool)
    if m:
        bad_comp[labels[non_orientable]] = True
        bad_comp[vertex_comp[nm_edges.ravel()]] = True
        bad_comp[vertex_comp[nm_verts]] = True
    genus_c = np.where(bad_comp, np.nan, (2 - chi_c - loops_c) / 2.0)
    genus = None if (bad_comp.any() or np.any(genus_c % 1 != 0)) else int(genus_c.sum())
    n_inconsistent = len(w.inconsistent_edges())
    return TopologyReport(
        n_vertices=int(len(np.unique(w.triangles))) if m else 0,
        n_triangles=m,
        n_edges=int(len(edges)),
        n_boundary_edges=int(len(bnd)),
        n_boundary_loops=int(loops_c.sum()),
        n_non_manifold_edges=int(len(nm_edges)),
        n_non_manifold_vertices=int(len(nm_verts)),
        is_watertight=w.is_watertight(),
        n_inconsistent_edges=int(n_inconsistent),
        is_consistently_oriented=n_inconsistent == 0,
        is_orientable=not bool(non_orientable.any()),
        n_flipped_triangles=int(flip.sum()),
        flipped_triangles=np.flatnonzero(flip).astype(np.int64),
        n_components=n_comp,
        euler_characteristic=int(chi_c.sum()),
        component_euler=chi_c,
        component_boundary_loops=loops_c,
        component_genus=genus_c,
        genus=genus,
        n_welded_vertices=int(welded.n_merged),
        n_degenerate_after_weld=int(len(welded.dropped_triangles)),
        weld_tol=0.0 if weld_tol is None else float(weld_tol),
    )

"""Triangle meshes: `TriMesh` and its topology (edges, boundaries, manifoldness, orientation)."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # scipy loads on first use: the reader server (which builds no TriMesh) skips ~0.2 s
    from scipy import sparse

from ..errors import DegenerateError, MeshError, NonManifoldError
from ._arrays import as_float_array, as_index_array

__all__ = ["TriMesh"]


def compact_indices(tri: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """``np.unique(tri, return_inverse=True)`` for int64 indices in [0, n): the used indices in increasing
    order and each entry's rank among them (flat, int64), by a mask and a running count (no sort).

    >>> used, inv = compact_indices(np.array([[5, 2, 7], [2, 7, 9]]), 10)
    >>> used.tolist(), inv.tolist()
    ([2, 5, 7, 9], [1, 0, 2, 0, 2, 3])
    """
    flat = np.asarray(tri, dtype=np.int64).ravel()
    mask = np.zeros(max(int(n), 0), dtype=bool)
    mask[flat] = True
    rank = np.cumsum(mask, dtype=np.int64) - 1
    return np.flatnonzero(mask), rank[flat]


@dataclass(frozen=True, eq=False)
class TriMesh:
    """A triangle mesh.

    Parameters
    ----------
    vertices : (n, 3) float64
    triangles : (m, 3) int64
        Counter-clockwise seen from the side the normal points to.
    uv : (n, 2) float64 or None
        Per-vertex surface parameters (when the mesh tessellates one surface).
    face_id : (m,) int64 or None
        Per-triangle index of the CAD face it came from.

    Raises
    ------
    MeshError
        Non-finite coordinates, indices out of range, repeated indices in a triangle.
    """

    vertices: np.ndarray
    triangles: np.ndarray
    uv: np.ndarray | None = None
    face_id: np.ndarray | None = None

    def __post_init__(self) -> None:
        v = as_float_array(self.vertices, "vertices", ndim=2, last=3, error=MeshError)
        t = as_index_array(self.triangles, "triangles", ndim=2, last=3, error=MeshError)
        if t.size:
            lo, hi = int(t.min()), int(t.max())
            if lo < 0 or hi >= len(v):
                bad = int(np.argmax((t < 0).any(axis=1) | (t >= len(v)).any(axis=1)))
                raise MeshError(f"triangle {bad} has vertex index out of range [0, {len(v)}): {t[bad].tolist()}")
            rep = (t[:, 0] == t[:, 1]) | (t[:, 1] == t[:, 2]) | (t[:, 0] == t[:, 2])
            if rep.any():
                bad = int(np.argmax(rep))
                raise DegenerateError(f"triangle {bad} repeats a vertex: {t[bad].tolist()}")
        object.__setattr__(self, "vertices", v)
        object.__setattr__(self, "triangles", t)
        if self.uv is not None:
            uv = as_float_array(self.uv, "uv", ndim=2, last=2, error=MeshError)
            if len(uv) != len(v):
                raise MeshError(f"uv must have shape ({len(v)}, 2); got {uv.shape}")
            object.__setattr__(self, "uv", uv)
        if self.face_id is not None:
            fid = as_index_array(self.face_id, "face_id", ndim=1, error=MeshError)
            if len(fid) != len(t):
                raise MeshError(f"face_id must have shape ({len(t)},); got {fid.shape}")
            object.__setattr__(self, "face_id", fid)

    # -- sizes ---------------------------------------------------------------
    @property
    def n_vertices(self) -> int:
        return int(self.vertices.shape[0])

    @property
    def n_triangles(self) -> int:
        return int(self.triangles.shape[0])

    # -- geometry ------------------------------------------------------------
    def triangle_normals(self) -> np.ndarray:
        """Unnormalised normals (twice the area vector), shape (m, 3)."""
        p = self.vertices[self.triangles]
        return np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])

    def triangle_areas(self) -> np.ndarray:
        return 0.5 * np.linalg.norm(self.triangle_normals(), axis=1)

    def area(self) -> float:
        return float(self.triangle_areas().sum())

    def bounding_box(self) -> tuple[np.ndarray, np.ndarray]:
        return self.vertices.min(axis=0), self.vertices.max(axis=0)

    def diagonal(self) -> float:
        if not self.n_vertices:
            return 0.0
        lo, hi = self.bounding_box()
        return float(np.linalg.norm(hi - lo))

    def degenerate_triangles(self, rel_area: float = 1e-14) -> np.ndarray:
        """Indices of triangles whose area is below rel_area * diagonal**2."""
        return np.flatnonzero(self.triangle_areas() <= rel_area * self.diagonal() ** 2)

    def check_degenerate(self, rel_area: float = 1e-14) -> None:
        """Raise `DegenerateError` naming the first zero-area triangle."""
        bad = self.degenerate_triangles(rel_area)
        if bad.size:
            raise DegenerateError(f"{bad.size} degenerate (zero-area) triangles, first is {int(bad[0])}: "
                                  f"{self.triangles[bad[0]].tolist()}")

    # -- topology ------------------------------------------------------------
    @cached_property
    def _half_edges(self) -> np.ndarray:
        t = self.triangles
        he = np.stack([t, np.roll(t, -1, axis=1)], axis=2).reshape(-1, 2)
        he.setflags(write=False)  # cached and handed out: keep it immutable
        return he

    @cached_property
    def _edge_index(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(unique undirected edges (k,2), half-edge -> edge index, count per edge)."""
        he = self._half_edges
        n = max(self.n_vertices, 1)
        # one int64 key per undirected edge (i < j): a 1-D unique is several times faster than axis=0
        key = np.minimum(he[:, 0], he[:, 1]) * n + np.maximum(he[:, 0], he[:, 1])
        keys, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)
        out = (np.column_stack([keys // n, keys % n]).astype(np.int64), inverse.ravel().astype(np.int64),
               counts.astype(np.int64))
        for a in out:
            a.setflags(write=False)
        return out

    def half_edges(self) -> np.ndarray:
        """Directed edges (3 m, 2): row 3 t + c runs from corner c to corner c + 1 of triangle t."""
        return self._half_edges

    def half_edge_edges(self) -> np.ndarray:
        """Index into `edges()` of every half-edge, shape (3 m,)."""
        return self._edge_index[1]

    def edges(self) -> np.ndarray:
        """Unique undirected edges (k, 2), each sorted (i < j)."""
        return self._edge_index[0]

    def edge_triangle_counts(self) -> np.ndarray:
        """Number of triangles on each edge of `edges()`, shape (k,)."""
        return self._edge_index[2]

    def boundary_edges(self) -> np.ndarray:
        """Directed boundary half-edges (k, 2), oriented as in their triangle."""
        _, inv, counts = self._edge_index
        return self._half_edges[counts[inv] == 1]

    def non_manifold_edges(self) -> np.ndarray:
        """Undirected edges with more than two triangles, (k, 2)."""
        edges, _, counts = self._edge_index
        return edges[counts > 2]

    def non_manifold_vertices(self) -> np.ndarray:
        """Vertices whose triangles form more than one fan, sorted (k,) int64.

        The triangles around a manifold vertex are joined, through the edges
        at that vertex, into one fan (a disk, or a half-disk on a boundary).
        A vertex where two fans meet only at the vertex (a "bow tie") is
        non-manifold. Vertices on non-manifold edges are reported by
        `non_manifold_edges` and count here only if their fans also split.
        """
        t = self.triangles
        m = len(t)
        if not m:
            return np.zeros(0, dtype=np.int64)
        _, inv, _ = self._edge_index
        he = self._half_edges
        corner = np.arange(3 * m).reshape(m, 3)
        # half-edge k = (t[i, c], t[i, c+1]): corner ids of its start and end vertex in triangle i
        c_start = corner.ravel()
        c_end = np.roll(corner, -1, axis=1).ravel()
        order = np.argsort(inv, kind="stable")
        same = inv[order][1:] == inv[order][:-1]
        h1, h2 = order[:-1][same], order[1:][same]  # consecutive half-edges of one undirected edge
        # join the corners at the same vertex across the shared edge
        start_same = he[h1, 0] == he[h2, 0]
        a1 = c_start[h1]
        b1 = np.where(start_same, c_start[h2], c_end[h2])
        a2 = c_end[h1]
        b2 = np.where(start_same, c_end[h2], c_start[h2])
        rows = np.r_[a1, a2]
        cols = np.r_[b1, b2]
        from scipy import sparse
        from scipy.sparse import csgraph
        g = sparse.coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(3 * m, 3 * m))
        _, label = csgraph.connected_components(g, directed=False)
        n_labels = int(label.max()) + 1
        vertex_fan = np.unique(t.ravel() * n_labels + label)  # distinct (vertex, fan) pairs
        fans = np.bincount(vertex_fan // n_labels, minlength=self.n_vertices)
        return np.flatnonzero(fans > 1).astype(np.int64)

    def is_watertight(self) -> bool:
        """Every edge has exactly two triangles."""
        return bool(self.n_triangles) and bool(np.all(self.edge_triangle_counts() == 2))

    def boundary_loops(self) -> list[np.ndarray]:
        """Boundary loops as vertex index arrays, longest first.

        Raises MeshError where a boundary vertex has more than one outgoing
        boundary edge (a non-manifold vertex).
        """
        be = self.boundary_edges()
        if not len(be):
            return []
        nxt: dict[int, int] = {}
        for a, b in be.tolist():
            if a in nxt:
                raise MeshError(f"vertex {a} has two outgoing boundary edges (non-manifold vertex)")
            nxt[a] = b
        loops, seen = [], set()
        for start in nxt:
            if start in seen:
                continue
            loop, v = [], start
            while v not in seen:
                seen.add(v)
                loop.append(v)
                v = nxt.get(v, start)
            loops.append(np.array(loop, dtype=np.int64))
        return sorted(loops, key=len, reverse=True)

    def connected_components(self) -> np.ndarray:
        """Component label per triangle (triangles sharing an edge are connected), shape (m,)."""
        _, inv, _ = self._edge_index
        m = self.n_triangles
        tri_of_he = np.repeat(np.arange(m), 3)
        from scipy import sparse
        from scipy.sparse import csgraph
        g = sparse.coo_matrix((np.ones(3 * m), (tri_of_he, inv)), shape=(m, inv.max() + 1 if m else 0)).tocsr()
        adj = g @ g.T
        _, labels = csgraph.connected_components(adj, directed=False)
        return labels.astype(np.int64)

    def n_components(self) -> int:
        return int(self.connected_components().max() + 1) if self.n_triangles else 0

    def inconsistent_edges(self) -> np.ndarray:
        """Manifold interior edges whose two triangles run it in the same direction, (k, 2).

        A consistently oriented mesh has none.
        """
        he = self._half_edges
        _, inv, counts = self._edge_index
        interior = counts[inv] == 2
        forward = he[:, 0] < he[:, 1]
        n_forward = np.bincount(inv[interior], weights=forward[interior], minlength=len(counts))
        bad = (counts == 2) & (n_forward != 1)
        return self.edges()[bad]

    def is_consistently_oriented(self) -> bool:
        return not len(self.inconsistent_edges())

    def check_manifold(self, name: str = "mesh", *, rel_area: float = 1e-14) -> None:
        """Raise unless this is a clean, consistently oriented 2-manifold (closed or with boundary).

        Checks, in order: no triangles, non-manifold edges, non-manifold vertices (bow ties), vertices in
        no triangle, zero-area triangles (area <= rel_area * diagonal**2), inconsistent orientation.
        Messages start with `name` and give the count and the first offender.

        Raises
        ------
        MeshError, NonManifoldError, DegenerateError
        """
        if self.n_triangles == 0:
            raise MeshError(f"{name}: the mesh has no triangles")
        nm = self.non_manifold_edges()
        if len(nm):
            raise NonManifoldError(f"{name}: not a 2-manifold: {len(nm)} non-manifold edges (in more than two "
                                   f"triangles), first is {nm[0].tolist()}")
        nv = self.non_manifold_vertices()
        if len(nv):
            raise NonManifoldError(f"{name}: not a 2-manifold: {len(nv)} non-manifold vertex(es) where separate "
                                   f"triangle fans meet (bow ties), first is vertex {int(nv[0])}")
        used = np.zeros(self.n_vertices, dtype=bool)
        used[self.triangles.ravel()] = True
        if not used.all():
            raise MeshError(f"{name}: {int((~used).sum())} isolated vertices (in no triangle), first is "
                            f"{int(np.argmin(used))}; remove unused vertices first")
        bad = self.degenerate_triangles(rel_area)
        if bad.size:
            raise DegenerateError(f"{name}: {bad.size} degenerate (zero-area) triangle(s), first is {int(bad[0])}: "
                                  f"{self.triangles[bad[0]].tolist()}")
        if not self.is_consistently_oriented():
            e = self.inconsistent_edges()
            raise MeshError(f"{name}: triangles are not consistently oriented ({len(e)} edge(s), first is "
                            f"{e[0].tolist()}); orient the mesh first")

    def euler_characteristic(self) -> int:
        used = np.unique(self.triangles)
        return int(len(used) - len(self.edges()) + self.n_triangles)

    def vertex_adjacency(self) -> sparse.csr_matrix:
        """Symmetric (n, n) sparse matrix with edge lengths as entries."""
        e = self.edges()
        w = np.linalg.norm(self.vertices[e[:, 0]] - self.vertices[e[:, 1]], axis=1)
        n = self.n_vertices
        from scipy import sparse
        a = sparse.coo_matrix((np.r_[w, w], (np.r_[e[:, 0], e[:, 1]], np.r_[e[:, 1], e[:, 0]])), shape=(n, n))
        return a.tocsr()

    def submesh(self, triangle_mask) -> "TriMesh":
        """The triangles selected by `triangle_mask`, with unused vertices dropped."""
        keep = np.asarray(triangle_mask)
        tris = self.triangles[keep]
        used, new = np.unique(tris, return_inverse=True)
        uv = None if self.uv is None else self.uv[used]
        fid = None if self.face_id is None else self.face_id[keep]
        return TriMesh(self.vertices[used], new.reshape(-1, 3), uv=uv, face_id=fid)

    def flipped(self) -> "TriMesh":
        """The same mesh with every triangle's orientation reversed."""
        return TriMesh(self.vertices, self.triangles[:, ::-1], uv=self.uv, face_id=self.face_id)

    # -- other libraries -----------------------------------------------------
    def to_trimesh(self):
        """A ``trimesh.Trimesh`` with the same vertices and triangles (copies, in order; nothing merged).

        ``uv`` goes to its ``visual.uv``, ``face_id`` to ``face_attributes["face_id"]``.

        Examples
        --------
        >>> m = TriMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
        >>> tm = m.to_trimesh()
        >>> tm.faces.tolist(), TriMesh.from_trimesh(tm).vertices.shape
        ([[0, 1, 2]], (3, 3))
        """
        import trimesh

        visual = None
        if self.uv is not None:
            from trimesh.visual import TextureVisuals
            visual = TextureVisuals(uv=np.array(self.uv))
        attributes = {} if self.face_id is None else {"face_id": np.array(self.face_id)}
        return trimesh.Trimesh(np.array(self.vertices), np.array(self.triangles), visual=visual,
                               face_attributes=attributes, process=False, validate=False)

    @classmethod
    def from_trimesh(cls, mesh) -> "TriMesh":
        """A `TriMesh` from a ``trimesh.Trimesh`` (vertices and faces as they are, uv and face_id when present).

        Raises
        ------
        MeshError
            `mesh` has no ``vertices``/``faces`` arrays, or they are invalid (see `TriMesh`).
        """
        if not (hasattr(mesh, "vertices") and hasattr(mesh, "faces")):
            raise MeshError(f"from_trimesh: expected a trimesh.Trimesh; got {type(mesh).__name__}")
        vertices = np.array(mesh.vertices, dtype=np.float64)
        triangles = np.array(mesh.faces, dtype=np.int64).reshape(-1, 3)
        uv = getattr(getattr(mesh, "visual", None), "uv", None)
        uv = None if uv is None or np.shape(uv) != (len(vertices), 2) else np.array(uv, dtype=np.float64)
        fid = getattr(mesh, "face_attributes", {}).get("face_id")
        fid = None if fid is None or np.shape(fid) != (len(triangles),) else np.array(fid, dtype=np.int64)
        return cls(vertices, triangles, uv=uv, face_id=fid)

    def to_pyvista(self):
        """A ``pyvista.PolyData`` with the same points and triangles (copies, in order).

        ``uv`` goes to the point data ``"uv"`` (also the active texture
        coordinates), ``face_id`` to the cell data ``"face_id"``.

        Examples
        --------
        >>> m = TriMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], face_id=[7])
        >>> pd = m.to_pyvista()
        >>> pd.n_cells, pd.cell_data["face_id"].tolist()
        (1, [7])
        """
        import pyvista

        faces = np.column_stack([np.full(self.n_triangles, 3, dtype=np.int64), self.triangles]).ravel()
        poly = pyvista.PolyData(np.array(self.vertices), faces=faces)
        if self.uv is not None:
            poly.point_data["uv"] = np.array(self.uv)
            poly.active_texture_coordinates = np.array(self.uv)
        if self.face_id is not None:
            poly.cell_data["face_id"] = np.array(self.face_id)
        return poly

    @classmethod
    def from_pyvista(cls, mesh) -> "TriMesh":
        """A `TriMesh` from a pyvista mesh of triangles (``PolyData``, or any ``DataSet`` whose cells are triangles).

        Points are kept in order (unused ones too); uv from the point data
        ``"uv"`` or the active texture coordinates, face_id from the cell data
        ``"face_id"``.

        Raises
        ------
        MeshError
            Not a pyvista mesh, or a cell that is not a triangle (triangulate
            first: ``mesh.triangulate()``); lines and vertices are refused too.
        """
        points = getattr(mesh, "points", None)
        if points is None or not hasattr(mesh, "n_cells"):
            raise MeshError(f"from_pyvista: expected a pyvista mesh; got {type(mesh).__name__}")
        vertices = np.array(points, dtype=np.float64).reshape(-1, 3)
        if hasattr(mesh, "faces") and hasattr(mesh, "n_lines") and not (mesh.n_lines or mesh.n_verts or
                                                                         getattr(mesh, "n_strips", 0)):
            raw = np.asarray(mesh.faces, dtype=np.int64)
            if len(raw) and (len(raw) % 4 or np.any(raw[::4] != 3)):
                raise MeshError("from_pyvista: the PolyData has faces that are not triangles; call "
                                ".triangulate() first")
            triangles = raw.reshape(-1, 4)[:, 1:]
        else:
            import pyvista

            cells = mesh.cells_dict if hasattr(mesh, "cells_dict") else {}
            other = sorted(int(k) for k in cells if int(k) != int(pyvista.CellType.TRIANGLE))
            if other or not cells:
                raise MeshError(f"from_pyvista: cells that are not triangles (VTK cell types {other}); "
                                "extract and triangulate the surface first: mesh.extract_surface().triangulate()")
            triangles = np.asarray(cells[int(pyvista.CellType.TRIANGLE)], dtype=np.int64).reshape(-1, 3)
        uv = mesh.point_data.get("uv") if "uv" in mesh.point_data else getattr(mesh, "active_texture_coordinates",
                                                                                  None)
        uv = None if uv is None or np.shape(uv) != (len(vertices), 2) else np.array(uv, dtype=np.float64)
        fid = mesh.cell_data["face_id"] if "face_id" in mesh.cell_data else None
        fid = None if fid is None or np.shape(fid) != (len(triangles),) else np.array(fid, dtype=np.int64)
        return cls(vertices, triangles, uv=uv, face_id=fid)

    def report(self) -> dict:
        """Sizes, bounding box, topology and triangle angles as a plain JSON-ready dict (`trimsurf.viz.report_of`)."""
        from ..viz._notebook import report_of  # higher layers: imported on use only

        return report_of(self)

    def to_table(self) -> list[dict]:
        """`report` as a one-row table (a list with one flat dict) that ``pandas.DataFrame`` accepts."""
        from ..viz._notebook import report_table

        return report_table(self)

    def _repr_html_(self) -> str:
        """The interactive viewer (inline, offline) and the mesh's figures, for Jupyter (`trimsurf.viz`)."""
        from ..viz._notebook import repr_html  # viz is a higher layer: imported on use only

        return repr_html(self)

"""Shells: faces, the edges they share, vertices and adjacency."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..errors import GeometryError
from ._arrays import as_float_array
from .nurbs import NurbsCurve
from .trim import TrimmedFace

__all__ = ["Edge", "Shell"]


@dataclass(frozen=True, slots=True, eq=False)
class Edge:
    """A topological edge of a shell.

    Parameters
    ----------
    curve : NurbsCurve or None
        3D curve b(t) of the edge on [t0, t1] (None for a degenerate edge, or
        an edge known by its p-curves only).
    t0, t1 : float
        The edge runs from b(t0) to b(t1). ``t0 > t1`` is allowed and means
        the edge runs against its curve's own direction; it is kept as given
        (not normalised), and the STEP writer handles it (Open CASCADE wants
        its FORWARD vertex at the low end of the range, so it swaps the
        vertex roles). The p-curves of `uses` share the parameter t with
        b(t) either way; each use's own direction is that of its segment
        (``PCurve.t0 > PCurve.t1`` runs against the curve). The STEP reader
        always returns ``t0 < t1``.
    vertices : (int, int)
        Indices into `Shell.vertices` of the vertex at b(t0) and the one at
        b(t1); -1 for an end without a vertex (e.g. a closed edge that Open
        CASCADE stores without vertices).
    uses : tuple of (face, loop, segment)
        Every loop segment that runs along this edge; two for a manifold
        interior edge, one for a free (boundary) edge.
    tolerance : float
        The source's stated tolerance of the edge (model units), 0 if unknown.
    """

    curve: NurbsCurve | None
    t0: float
    t1: float
    vertices: tuple[int, int]
    uses: tuple[tuple[int, int, int], ...]
    tolerance: float = 0.0
    is_degenerate: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "uses", tuple(tuple(int(i) for i in u) for u in self.uses))
        object.__setattr__(self, "vertices", (int(self.vertices[0]), int(self.vertices[1])))

    @property
    def faces(self) -> tuple[int, ...]:
        return tuple(sorted({u[0] for u in self.uses}))


@dataclass(frozen=True, slots=True, eq=False)
class Shell:
    """Trimmed faces with the edges and vertices they share.

    Parameters
    ----------
    faces : tuple of TrimmedFace
    edges : tuple of Edge
        Empty when the source carries no topology (VDAFS, IGES surfaces).
    vertices : (k, 3) float64
    name : str
        Source of the shell (file name or sample), for messages.
    """

    faces: tuple[TrimmedFace, ...]
    edges: tuple[Edge, ...] = ()
    vertices: np.ndarray = None  # type: ignore[assignment]
    name: str = ""
    _boxes: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "faces", tuple(self.faces))
        object.__setattr__(self, "edges", tuple(self.edges))
        verts = np.zeros((0, 3)) if self.vertices is None else self.vertices
        object.__setattr__(self, "vertices", as_float_array(verts, "Shell.vertices", ndim=2, last=3))
        n_faces, n_verts = len(self.faces), len(self.vertices)
        for i, e in enumerate(self.edges):
            for f, _, _ in e.uses:
                if not 0 <= f < n_faces:
                    raise GeometryError(f"Shell edge {i} refers to face {f}; shell has {n_faces}")
            if any(not -1 <= v < n_verts for v in e.vertices):
                raise GeometryError(f"Shell edge {i} refers to vertex {e.vertices}; shell has {n_verts} "
                                    "(-1 means no vertex)")

    @classmethod
    def from_faces(cls, faces: TrimmedFace | Sequence[TrimmedFace], *, name: str = "") -> Shell:
        """A shell without shared-edge topology (no edges, no vertices) holding `faces`.

        Parameters
        ----------
        faces : TrimmedFace or sequence of TrimmedFace
        name : str

        Returns
        -------
        Shell
            ``has_topology`` is False; the STEP writer sews such faces.

        Raises
        ------
        GeometryError
            An item of `faces` is not a `TrimmedFace`.

        Examples
        --------
        >>> shell = Shell.from_faces([], name="empty")
        >>> shell.has_topology, len(shell.vertices)
        (False, 0)
        """
        if isinstance(faces, TrimmedFace):
            faces = (faces,)
        faces = tuple(faces)
        for i, f in enumerate(faces):
            if not isinstance(f, TrimmedFace):
                raise GeometryError(f"Shell.from_faces: item {i} is a {type(f).__name__}, not a TrimmedFace")
        return cls(faces, name=name)

    @property
    def has_topology(self) -> bool:
        return bool(self.edges)

    def free_edges(self) -> list[int]:
        """Indices of edges used by exactly one face side (boundary of an open shell)."""
        return [i for i, e in enumerate(self.edges) if len(e.uses) == 1 and not e.is_degenerate]

    def non_manifold_edges(self) -> list[int]:
        """Indices of edges used by more than two face sides."""
        return [i for i, e in enumerate(self.edges) if len(e.uses) > 2]

    def is_closed(self) -> bool:
        return self.has_topology and not self.free_edges()

    def adjacency(self) -> dict[int, set[int]]:
        """Face index -> indices of faces sharing an edge with it."""
        adj: dict[int, set[int]] = {i: set() for i in range(len(self.faces))}
        for e in self.edges:
            fs = e.faces
            for a in fs:
                for b in fs:
                    if a != b:
                        adj[a].add(b)
        return adj

    def bounding_box(self, n: int = 17) -> tuple[np.ndarray, np.ndarray]:
        """Axis-aligned box of the trimmed faces, from points sampled inside their trims.

        Each face contributes `TrimmedFace.sample_points` (its loops, and an `n` x `n` grid of the
        loops' (u, v) box inside them), never its untrimmed surface or control net: a face trimmed
        to a small part of a huge surface counts with that part only. A sampled bound: the true box
        is at least this one and larger by at most the faces' bulge between samples. Every default
        that derives from `diagonal` (tolerances, grid sizes) inherits it.

        Examples
        --------
        >>> from trimsurf.samples import build_sample
        >>> lo, hi = build_sample("bspline_box").bounding_box()
        >>> bool(np.all(hi > lo))
        True
        """
        n = int(n)
        if n not in self._boxes:          # the shell is frozen: its box is computed once per n
            lo = np.full(3, np.inf)
            hi = np.full(3, -np.inf)
            for f in self.faces:
                pts = f.sample_points(n)
                if len(pts):
                    lo = np.minimum(lo, pts.min(axis=0))
                    hi = np.maximum(hi, pts.max(axis=0))
            self._boxes[n] = (lo, hi)
        lo, hi = self._boxes[n]
        return lo.copy(), hi.copy()

    def diagonal(self) -> float:
        """Diagonal of `bounding_box` (model units): the extent every default tolerance derives from."""
        lo, hi = self.bounding_box()
        with np.errstate(all="ignore"):
            return float(np.linalg.norm(hi - lo))

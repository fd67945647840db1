"""The topology of one half-edge collapse v -> u, shared by the sliver and the seam reduction."""

from __future__ import annotations

import numpy as np
from numba import njit

from .._numba_load import install as _install_lazy_bitcode

_install_lazy_bitcode()     # before this module's kernels load (trimsurf._numba_load)

__all__ = ["collapse_sets", "vertex_triangles"]


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def vertex_triangles(T, idx, nv):
    """Vertex -> triangles in CSR form over the triangles T[idx] (in idx order): the triangles of vertex w
    are ``vtri[start[w]:start[w + 1]]`` (the compiled kernels' `collapse_sets` input)."""
    m = idx.shape[0]
    start = np.zeros(nv + 1, dtype=np.int64)
    for r in range(m):
        for c in range(3):
            start[T[idx[r], c] + 1] += 1
    for w in range(nv):
        start[w + 1] += start[w]
    fill = start[:-1].copy()
    vtri = np.empty(3 * m, dtype=np.int64)
    for r in range(m):
        t = idx[r]
        for c in range(3):
            w = T[t, c]
            vtri[fill[w]] = t
            fill[w] += 1
    return start, vtri


def collapse_sets(Tl: list, vtri, vstart, v: int, u: int):
    """What collapsing vertex v into its neighbour u touches.

    Parameters
    ----------
    Tl : list of [a, b, c]
        The triangles as Python lists (walked per candidate: a few sets beat numpy here).
    vtri, vstart : list of int
        Vertex -> alive triangles in CSR form: the triangles of v are ``vtri[vstart[v]:vstart[v + 1]]``.
    v, u : int

    Returns
    -------
    tv : list
        The triangles of v.
    star : set
        The vertices of those triangles (v's closed star; lock them so collapses of one round are
        independent).
    common : set
        Neighbours of both v and u (the link condition: a manifold collapse has as many as triangles go).
    gone, moved : list
        v's triangles that hold u (they vanish) and the others (v becomes u in them).
    """
    tv = vtri[vstart[v]:vstart[v + 1]]
    star = {x for k in tv for x in Tl[k]}
    nu = {x for k in vtri[vstart[u]:vstart[u + 1]] for x in Tl[k]} - {u}
    gone = [k for k in tv if u in Tl[k]]
    moved = [k for k in tv if u not in Tl[k]]
    return tv, star, (star - {v}) & nu, gone, moved

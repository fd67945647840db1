"""The topology of one half-edge collapse v -> u, shared by the sliver and the seam reduction."""

from __future__ import annotations

import numpy as np
from numba import njit

from .._numba_load import install as _install_lazy_bitcode

_install_lazy_bitcode()     # before this module's kernels load (trimsurf._numba_load)

__all__ = ["collapse_sets", "common_neighbours", "take_collapse", "vertex_triangles"]


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


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def common_neighbours(T, start, vtri, v, u, q, in_nu, counted):
    """How many vertices other than v and u are neighbours of both (the link condition of the collapse
    v -> u: a manifold collapse has as many as triangles go), over the CSR `vertex_triangles`; in_nu and
    counted (nv,) are scratch marks, stamped with the candidate's number q (never stamped before)."""
    for r in range(start[u], start[u + 1]):
        t = vtri[r]
        for c in range(3):
            in_nu[T[t, c]] = q
    n_common = 0
    for r in range(start[v], start[v + 1]):
        t = vtri[r]
        for c in range(3):
            x = T[t, c]
            if x != v and x != u and in_nu[x] == q and counted[x] != q:
                counted[x] = q
                n_common += 1
    return n_common


@njit(cache=True, nogil=True, no_cpython_wrapper=True)
def take_collapse(T, start, vtri, v, u, locked, moved, n_moved, gone, n_gone):
    """Take the collapse v -> u: v's triangles that hold u appended to gone, the others to moved (in CSR
    order), v's star locked; returns the new (n_moved, n_gone)."""
    for r in range(start[v], start[v + 1]):
        t = vtri[r]
        if T[t, 0] == u or T[t, 1] == u or T[t, 2] == u:
            gone[n_gone] = t
            n_gone += 1
        else:
            moved[n_moved] = t
            n_moved += 1
        for c in range(3):
            locked[T[t, c]] = True
    return n_moved, n_gone


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

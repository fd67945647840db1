"""The topology of one half-edge collapse v -> u, shared by the sliver and the seam reduction."""

from __future__ import annotations

__all__ = ["collapse_sets"]


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

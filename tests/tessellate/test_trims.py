"""Shared-edge trim polygons (trims.discretize_chunk): every grid-line crossing of both faces, chords
within the shared-edge tolerance, and no 3D sample left next to a crossing."""

from __future__ import annotations

import numpy as np
import pytest

from trimsurf.io import read_shell
from trimsurf.tessellate.face import face_domain_values
from trimsurf.tessellate.trims import SHARED_CHORD, ChunkUse, discretize_chunk


def _ptol(face) -> float:
    (u0, u1), (v0, v1) = face.surface.domain
    return 1e-7 * min(u1 - u0, v1 - v0)


def _shared_chunks(shell, tol: float, h: float):
    """Every edge of the shell used by two face segments, discretized as tessellate_shell does."""
    faces = shell.faces
    grids = {}
    chunks = []
    for edge_index, edge in enumerate(shell.edges):
        if edge.is_degenerate or len(edge.uses) != 2:
            continue
        uses = []
        for fi, li, si in edge.uses:
            seg = faces[fi].loops[li].segments[si]
            if seg.edge_id != edge_index:
                break
            if fi not in grids:
                grids[fi] = face_domain_values(faces[fi], tolerance=tol, max_edge=h)
            us, vs = grids[fi]
            uses.append(ChunkUse(fi, li, si, seg, faces[fi].surface, us, vs, _ptol(faces[fi])))
        if len(uses) == 2:
            chunks.append(discretize_chunk(uses, tolerance=tol, max_edge=h))
    return chunks


@pytest.fixture(scope="module")
def t20(shared_data):
    """gmsh__t20_data.step at the benchmark's tolerance-only setting: planar rings whose circles are
    shared with cylinders that have many iso-lines along them (the other face has none)."""
    shell = read_shell(shared_data / "cad" / "gmsh__t20_data.step")
    d = shell.diagonal()
    tol = 1e-3 * d
    return tol, _shared_chunks(shell, tol, d)


@pytest.fixture(scope="module")
def t20_fine(shared_data):
    """t20 at half the benchmark's tolerance: there its shared arcs still get points between the
    crossings (at 1e-3 x diagonal every point of its shared edges is a crossing since the shared-edge chord
    tolerance is the faces' own, SHARED_CHORD = 0.97)."""
    shell = read_shell(shared_data / "cad" / "gmsh__t20_data.step")
    d = shell.diagonal()
    tol = 5e-4 * d
    return tol, _shared_chunks(shell, tol, d)


def _on_line(use, uv):
    return np.isin(uv[:, 0], use.us) | np.isin(uv[:, 1], use.vs)


def test_shared_chunks_keep_every_crossing_and_the_chord_tolerance(t20):
    tol, chunks = t20
    assert len(chunks) > 20
    worst = 0.0
    for c in chunks:
        assert c.s[0] == 0.0 and c.s[-1] == 1.0 and np.all(np.diff(c.s) > 0)
        for use, uv in zip(c.uses, c.uv):
            # no chord crosses a grid line of the face: both ends in one closed cell
            for axis, grid in ((0, use.us), (1, use.vs)):
                i = np.searchsorted(grid, np.minimum(uv[:-1, axis], uv[1:, axis]), side="right")
                j = np.searchsorted(grid, np.maximum(uv[:-1, axis], uv[1:, axis]), side="left")
                assert np.all(i >= j)
            # the curve on this face, densely sampled, stays within the shared-edge chord tolerance
            f = np.linspace(0.0, 1.0, 33)[1:-1]
            ss = (c.s[:-1, None] + np.diff(c.s)[:, None] * f[None, :]).ravel()
            p = use.surface.evaluate(use.uv(ss)).reshape(len(c.s) - 1, len(f), 3)
            ends = use.surface.evaluate(uv)
            a, b = ends[:-1, None, :], ends[1:, None, :]
            ab = b - a
            w = np.clip(np.einsum("nkd,nkd->nk", p - a, ab) / np.maximum(np.einsum("nkd,nkd->nk", ab, ab), 1e-300),
                        0.0, 1.0)
            dist = np.linalg.norm(p - (a + w[..., None] * ab), axis=-1)
            worst = max(worst, float(dist.max()))
    # the samples the discretization checks are fewer: a little above SHARED_CHORD, within the tolerance
    assert worst <= tol
    assert worst >= 0.5 * SHARED_CHORD * tol       # the chords are used, not over-refined


def test_no_3d_sample_next_to_a_crossing(t20_fine):
    """A point that is no grid-line crossing of either face is spaced evenly between the crossings:
    never within a quarter of its other neighbour's distance of a point (before: 3D samples 0.7 x
    tolerance short of a cylinder's line crossings, 37 x tolerance from the next point, gave the
    plane's ring cells thin triangle fans)."""
    tol, chunks = t20_fine
    n_free = 0
    for c in chunks:
        crossing = np.zeros(len(c.s), dtype=bool)
        for use, uv in zip(c.uses, c.uv):
            for axis, grid in ((0, use.us), (1, use.vs)):
                x = uv[:, axis]
                along = np.zeros(len(x), dtype=bool)
                along[1:-1] = (x[:-2] == x[1:-1]) & (x[2:] == x[1:-1])
                crossing |= np.isin(x, grid) & ~along
        gaps = np.linalg.norm(np.diff(c.xyz, axis=0), axis=1)
        for k in np.flatnonzero(~crossing[1:-1]) + 1:
            n_free += 1
            lo, hi = sorted((gaps[k - 1], gaps[k]))
            assert lo >= 0.25 * hi, (k, gaps[k - 1] / tol, gaps[k] / tol)
    assert n_free > 0

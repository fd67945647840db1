"""Work the edge stage skips without changing a number (session 28): the chunk criteria's uses after one
over a limit, and the seam deviation's derivatives. Each against the full evaluation it replaces."""

from __future__ import annotations

import numpy as np
import pytest

from trimsurf.io import read_shell
from trimsurf.tessellate.face import face_domain_values
from trimsurf.tessellate.trims import ChunkUse, _ChunkLines


def _shared_chunks(shell, tol, h):
    """The edges' uses (as tessellate_shell builds them) of the edges with two uses."""
    grids, chunks = {}, []
    for e in shell.edges:
        if len(e.uses) != 2 or e.is_degenerate:
            continue
        uses = []
        for fi, li, si in e.uses:
            f = shell.faces[fi]
            if fi not in grids:
                grids[fi] = face_domain_values(f, tolerance=0.97 * tol, max_edge=h)
            us, vs = grids[fi]
            (u0, u1), (v0, v1) = f.surface.domain
            uses.append(ChunkUse(fi, li, si, f.loops[li].segments[si], f.surface, us, vs,
                                 1e-7 * min(u1 - u0, v1 - v0)))
        chunks.append(uses)
    return chunks


def _caller():
    from numba import njit

    from trimsurf.tessellate._line_kernels import _chunk_criteria

    @njit
    def call(fam, a, b, m, max_len, max_dev, stop):
        length, dev = np.full(a.shape[0], -1.0), np.full(a.shape[0], -1.0)
        ok = _chunk_criteria(fam[10], fam[11], fam[12], fam[13], fam[14], fam[15], fam[16], a, b, m, length, dev,
                             max_len, max_dev, stop, np.empty(0), np.empty(0))
        return ok, length, dev

    return call


def test_chunk_criteria_with_limits_skip_only_intervals_over_them(shared_data):
    # With finite limits (the reduction's call, stop False) an interval over one after its first use skips
    # the second use: its values must still be over a limit, every other interval's the full evaluation's
    # bit for bit, also right after a skipped one (whose second use's end point was not evaluated: the
    # next interval evaluates it again instead of reusing it). With stop the verdict and the values up to
    # the first failing interval are the full evaluation's.
    shell = read_shell(shared_data / "cad" / "gmsh__t20_data.step")
    d = shell.diagonal()
    call = _caller()
    rng = np.random.default_rng(3)
    n_skip = n_after = n_stop = 0
    for uses in _shared_chunks(shell, 1e-3 * d, d):
        f = _ChunkLines(uses).family()
        x = np.unique(np.r_[0.0, rng.random(30), 1.0])
        a, b = x[:-1].copy(), x[1:].copy()
        m = np.int64(9)
        _, ln, dv = call(f, a, b, m, np.inf, np.inf, False)
        for q in (0.3, 0.6):
            max_len, max_dev = np.inf, float(np.quantile(dv, q))
            if q == 0.6:
                max_len, max_dev = float(np.quantile(ln, q)), np.inf
            ok, gl, gd = call(f, a, b, m, max_len, max_dev, False)
            assert ok
            within = (ln <= max_len) & (dv <= max_dev)
            assert gl[within].tobytes() == ln[within].tobytes() and gd[within].tobytes() == dv[within].tobytes()
            assert not ((gl[~within] <= max_len) & (gd[~within] <= max_dev)).any()
            skipped = (gl != ln) | (gd != dv)
            n_skip += int(skipped.sum())
            n_after += int((within[1:] & skipped[:-1]).sum())
            ok, sl, sd = call(f, a, b, m, max_len, max_dev, True)
            first = int(np.argmin(within)) if not within.all() else len(a)
            assert ok == within.all()
            assert sl[:first].tobytes() == ln[:first].tobytes() and sd[:first].tobytes() == dv[:first].tobytes()
            if first < len(a):
                assert not (sl[first] <= max_len and sd[first] <= max_dev)
                n_stop += 1
    assert n_skip >= 20 and n_after >= 10 and n_stop >= 10


@pytest.mark.parametrize("fname", ["gmsh__U_Joint_2.stp", "occt__bearing.iges"])
def test_multi_derivatives_s_alone_is_the_same_s(shared_data, fname):
    # `seams._multi_derivatives_kernel` with the first n0 points S alone (the seam deviation's points): the
    # same S bit for bit as with their derivatives, and the other points' S, S_u, S_v untouched
    from trimsurf.tessellate import seams as seams_mod

    faces = list(read_shell(shared_data / "cad" / fname).faces)
    rng = np.random.default_rng(4)
    m = 3000
    face_of = rng.integers(0, len(faces), m).astype(np.int64)
    pts = np.empty((m, 2))
    for k in range(m):
        (u0, u1), (v0, v1) = faces[face_of[k]].surface.domain
        t = rng.choice([rng.uniform(-0.1, 1.1), 0.0, 1.0, rng.uniform(0, 1)], 2)
        pts[k] = u0 + t[0] * (u1 - u0), v0 + t[1] * (v1 - v0)
    packed = seams_mod._packed(faces)[0]
    order = np.argsort(face_of, kind="stable")
    u, v = pts[:, 0].copy(), pts[:, 1].copy()
    ref = np.full((3, m, 3), 7.0)
    seams_mod._multi_derivatives_kernel(*packed, face_of, u, v, order, np.int64(0), ref)
    n0 = m // 2
    got = np.full((3, m, 3), 7.0)
    seams_mod._multi_derivatives_kernel(*packed, face_of, u, v, order, np.int64(n0), got)
    assert got[0].tobytes() == ref[0].tobytes()
    assert got[1:, n0:].tobytes() == ref[1:, n0:].tobytes()
    assert (got[1:, :n0] == 7.0).all()

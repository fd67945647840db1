"""The reader's own cost (issue 17, item 2): p-curves evaluated without numba, bit for bit; the reader server
starts without loading numba's compiled kernels; faces converted in batches fail as one at a time did.

`trimsurf.io._occ._geometry.curves_points` replaces ``NurbsCurve.evaluate`` (the compiled kernel) in the
reader, so its results must be the same floats: the (u, v) range of each face decides the surface's domain
extension, i.e. the knots written into the shell.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from trimsurf.errors import FaceSkippedWarning, GeometryError
from trimsurf.io import _occ, _step
from trimsurf.io._occ import _to_shell
from trimsurf.io._occ._geometry import curve_points, curves_points, linspaces
from trimsurf.model import NurbsCurve

SRC = str(Path(_occ.__file__).resolve().parents[3])


def _curves(shell):
    pcurves = [s for f in shell.faces for lp in f.loops for s in lp.segments]
    return [s.curve for s in pcurves], [e.curve for e in shell.edges if e.curve is not None], pcurves


@pytest.mark.parametrize("name", ["occt__screw.step", "gmsh__t20_data.step", "occtpr946__ec_turbine-A.stp"])
def test_batched_points_are_the_compiled_kernels_floats(shared_data, name):
    shell = _step.read_in_process(shared_data / "cad" / name)
    pcs, edges, segs = _curves(shell)
    rng = np.random.default_rng(3)
    for curves in (pcs, edges):
        ts = []
        for c in curves:
            a, b = c.domain
            # inside, at every knot (span ends, repeated knots, the domain end), and outside (clamped)
            ts.append(np.concatenate([rng.uniform(a, b, 7), c.knots, [a - (b - a), b + 0.5 * (b - a)]]))
        got = curves_points(curves, ts)
        for c, t, g in zip(curves, ts, got):
            assert g.tobytes() == c.evaluate(t).tobytes()
        one = curves[len(curves) // 2]
        assert curve_points(one, ts[len(curves) // 2]).tobytes() == one.evaluate(ts[len(curves) // 2]).tobytes()
    # the reader's samples: np.linspace's floats, all segments at once
    t0, t1 = np.array([s.t0 for s in segs]), np.array([s.t1 for s in segs])
    ts = linspaces(t0, t1, 65)
    for s, t in zip(segs, ts):
        assert t.tobytes() == np.linspace(s.t0, s.t1, 65).tobytes()


def test_rational_and_polynomial_curves_of_one_degree_in_one_batch():
    arc = NurbsCurve(2, [0, 0, 0, 1, 1, 1], [[1.0, 0.0], [1.0, 1.0], [0.0, 1.0]], [1.0, np.sqrt(0.5), 1.0])
    par = NurbsCurve(2, [0, 0, 0, 0.3, 1, 1, 1], [[0.0, 0.0], [0.3, 1.0], [0.7, -1.0], [1.0, 0.0]])
    ts = [np.linspace(-0.1, 1.1, 50), np.array([0.0, 0.3, 0.30000000000000004, 1.0])]
    a, b = curves_points([arc, par], ts)
    assert a.tobytes() == arc.evaluate(ts[0]).tobytes()
    assert b.tobytes() == par.evaluate(ts[1]).tobytes()
    # the rational arc is on the unit circle (the division by the weight sum happened), the parabola is not
    assert np.allclose(np.hypot(*a.T), 1.0, rtol=0, atol=1e-15)


def test_the_reader_server_start_loads_no_compiled_kernel(shared_data):
    # what the server imports and its warm-up, then a read as a child does: numba's kernels stay unloaded
    # (loading the first one imports scipy.linalg: ~0.2 s of every command's first read)
    code = (
        "import sys, json\n"
        "from trimsurf.io._occ import _worker\n"
        "_worker._warm_up()\n"
        "from trimsurf.io._occ._isolate import convert_file\n"
        "shell = convert_file(sys.argv[1], 'STEP')\n"
        "from numba.core.registry import CPUDispatcher\n"
        "import gc\n"
        "loaded = [d.py_func.__name__ for d in gc.get_objects() if isinstance(d, CPUDispatcher) and d.overloads]\n"
        "print(json.dumps([len(shell.faces), loaded, 'scipy.linalg' in sys.modules]))\n")
    env = dict(os.environ, PYTHONPATH=SRC)
    run = subprocess.run([sys.executable, "-c", code, str(shared_data / "cad" / "occtpr946__ec_turbine-A.stp")],
                         capture_output=True, text=True, env=env, timeout=300)
    assert run.returncode == 0, run.stderr
    n_faces, loaded, linalg = json.loads(run.stdout.strip().splitlines()[-1])
    assert n_faces == 53 and loaded == [] and not linalg


def _fail(monkeypatch, loops_face: int, surface_call: int):
    """Face `loops_face` fails in its loops; the `surface_call`-th surface conversion (0-based) fails."""
    real_loops, real_surface = _to_shell._face_loops, _to_shell.surface_from_occ
    calls = {"n": 0}

    def loops(fi, *args):
        if fi == loops_face:
            raise GeometryError(f"loops of face {fi} broken")
        return real_loops(fi, *args)

    def surface(*args):
        calls["n"] += 1
        if calls["n"] == surface_call + 1:
            raise GeometryError("surface broken")
        return real_surface(*args)

    monkeypatch.setattr(_to_shell, "_face_loops", loops)
    monkeypatch.setattr(_to_shell, "surface_from_occ", surface)


def test_failures_of_both_passes_are_reported_in_face_order(shared_data, monkeypatch):
    path = shared_data / "cad" / "gmsh__t20_data.step"
    shape = _step.read_occ_shape(path)
    # face 1 fails at its surface (the second pass), face 3 in its loops (the first pass)
    _fail(monkeypatch, 3, 1)
    with pytest.warns(FaceSkippedWarning) as caught:
        shell = _occ.shape_to_shell(shape, name="t20", skip_bad_faces=True)
    texts = [str(w.message) for w in caught if issubclass(w.category, FaceSkippedWarning)]
    assert texts == ["t20: face 1 skipped: GeometryError: surface broken",
                     "t20: face 3 skipped: GeometryError: loops of face 3 broken"]
    assert len(shell.faces) == 19
    # without skipping, the first failing face's error is raised, whichever pass it failed in
    _fail(monkeypatch, 3, 1)
    with pytest.raises(GeometryError, match="surface broken"):
        _occ.shape_to_shell(shape, name="t20")
    _fail(monkeypatch, 3, 5)  # the surface of face 5 would fail, but face 3 comes first
    with pytest.raises(GeometryError, match="loops of face 3 broken"):
        _occ.shape_to_shell(shape, name="t20")


def test_read_shell_starts_the_server_before_importing_the_readers_and_only_for_server_reads(tmp_path, monkeypatch):
    from trimsurf.errors import FileFormatError
    from trimsurf.io import _server, read_shell

    started = []

    class FakeServer:
        def __init__(self, *, early=False):
            started.append(early)

        def alive(self):
            return True

    monkeypatch.setattr(_server, "Server", FakeServer)
    monkeypatch.setattr(_server, "_SERVER", None)
    monkeypatch.delenv("TRIMSURF_OCC_IN_PROCESS", raising=False)
    step = tmp_path / "a.step"
    step.write_text("ISO-10303-21;\n")
    vda = tmp_path / "a.vda"
    vda.write_text("x\n")
    with pytest.raises(FileFormatError):
        read_shell(tmp_path / "missing.step")        # refused before any server starts
    _server.start_for(vda)                           # VDAFS is read by hand, in process
    assert started == []
    monkeypatch.setenv("TRIMSURF_OCC_IN_PROCESS", "1")
    _server.start_for(step)
    assert started == []
    monkeypatch.delenv("TRIMSURF_OCC_IN_PROCESS")
    _server.start_for(step)
    _server.start_for(step)                          # one server
    assert started == [False]
    # and read_shell asks for it before it imports the readers (and the model, numba) for the read
    order = []
    monkeypatch.setattr(_server, "start_for", lambda path: order.append("server"))
    import trimsurf.io as tio

    class Stop(Exception):
        pass

    def readers(path):
        order.append("readers")
        raise Stop

    monkeypatch.setattr(tio, "_cad_module", readers)
    with pytest.raises(Stop):
        read_shell(step)
    assert order == ["server", "readers"]


def test_batches_of_a_few_points_give_the_same_floats(shared_data, monkeypatch):
    from trimsurf.io._occ import _geometry

    shell = _step.read_in_process(shared_data / "cad" / "occt__screw.step")
    pcs, _, _ = _curves(shell)
    ts = [np.linspace(*c.domain, 23) for c in pcs]
    whole = curves_points(pcs, ts)
    monkeypatch.setattr(_geometry, "_BATCH_POINTS", 50)  # two curves a batch, or one
    for a, b, c, t in zip(curves_points(pcs, ts), whole, pcs, ts):
        assert a.tobytes() == b.tobytes() == c.evaluate(t).tobytes()

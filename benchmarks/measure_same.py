"""Do two checkouts report the same measurement figures on the same meshes? (issue 17, item 2)

Three steps, each run with the checkout's ``src`` first on PYTHONPATH:

1. ``meshes DIR``: tessellate every shared CAD file and the samples (fender, hood, bspline_box) at
   eps = 1e-3 x diagonal, tolerance only and at the defaults (max edge 3e-2 x diagonal), and pickle
   (shell, result) per run into DIR (34 files);
2. ``figures DIR OUT.json``: on each pickled mesh, `measure_result` (the report's figures) and
   `shell_deviation(density=3, n_domain=32)` (the benchmark's metric), every float as its repr;
3. ``compare A.json B.json [--rel R]``: the rows whose figures differ, field by field (timings left out).
   With ``--rel R`` (session 29: the figures may move in the last bits), a float field whose relative
   difference is at most R counts as the same; every other difference is printed with its relative
   size and whether B is larger (for a deviation or its bound: conservative) or SMALLER; the exit code is
   0 when no deviation figure of B is smaller than A's beyond R and every other field but
   ``deviation_samples`` (a count of the work) is equal.

Usage:
    PYTHONPATH=/old/src python benchmarks/measure_same.py meshes /tmp/m
    PYTHONPATH=/old/src python benchmarks/measure_same.py figures /tmp/m /tmp/old.json
    PYTHONPATH=$PWD/src python benchmarks/measure_same.py figures /tmp/m /tmp/new.json
    python benchmarks/measure_same.py compare /tmp/old.json /tmp/new.json
"""

from __future__ import annotations

import json
import pickle
import sys
import time
from pathlib import Path

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "cad"


def meshes(folder: str) -> None:
    from trimsurf.io import read_shell
    from trimsurf.samples import build_sample
    from trimsurf.tessellate import tessellate_shell

    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    names = sorted(p.name for p in DATA.iterdir() if p.suffix.lower() in (".step", ".stp", ".iges", ".igs"))
    for name in names + ["fender", "hood", "bspline_box"]:
        shell = build_sample(name) if "." not in name else read_shell(DATA / name)
        d = shell.diagonal()
        for mode, h in (("tol", d), ("defaults", 3e-2 * d)):
            r = tessellate_shell(shell, tolerance=1e-3 * d, max_edge=h, measure=False)
            (out / f"{name}__{mode}.pkl").write_bytes(pickle.dumps((shell, r)))
            print(name, mode, r.mesh.n_triangles, flush=True)


def figures(folder: str, out: str) -> None:
    import trimsurf.geom.projection as projection
    from trimsurf.quality.deviation import shell_deviation
    from trimsurf.tessellate.measure import measure_result

    rows = {}
    for f in sorted(Path(folder).glob("*.pkl")):
        shell, r = pickle.loads(f.read_bytes())
        projection._SEED_CACHE.clear()
        t = time.process_time()
        m = measure_result(r, shell)
        t = time.process_time() - t
        projection._SEED_CACHE.clear()
        sd = shell_deviation(r.mesh, shell, density=3, n_domain=32).as_dict()
        rec = {k: (repr(v) if isinstance(v, float) else v) for k, v in m.items() if isinstance(v, (int, float, str))}
        rec.update({"sd_" + k: (repr(v) if isinstance(v, float) else v) for k, v in sd.items()
                    if isinstance(v, (int, float))})
        rec["_cpu"] = t
        rows[f.stem] = rec
        print(f.stem, round(t, 3), flush=True)
    Path(out).write_text(json.dumps(rows, indent=1))


def compare_rel(a_path: str, b_path: str, rel: float) -> int:
    """`compare` with floats equal within `rel` (relative); see the module docstring."""
    a, b = json.loads(Path(a_path).read_text()), json.loads(Path(b_path).read_text())
    same = bad = larger = 0
    for k, ra in a.items():
        rb = b.get(k)
        if rb is None:
            print("missing", k)
            bad += 1
            continue
        notes = []
        for f, va in ra.items():
            vb = rb.get(f)
            if f.startswith("_") or "second" in f or va == vb:
                continue
            if f == "deviation_samples":
                notes.append(f"{f} {va} -> {vb}")
                continue
            try:
                x, y = float(va), float(vb)
            except (TypeError, ValueError):
                notes.append(f"{f} {va!r} -> {vb!r} DIFFERENT")
                bad += 1
                continue
            r = (y - x) / abs(x) if x else float("inf")
            if abs(r) <= rel:
                continue
            dev = "deviation" in f or f.startswith("sd_max") or f.startswith("sd_rms")
            if dev and y > x:
                notes.append(f"{f} {va} -> {vb} ({r:+.2e}, larger)")
                larger += 1
            else:
                notes.append(f"{f} {va} -> {vb} ({r:+.2e}, {'SMALLER' if dev else 'DIFFERENT'})")
                bad += 1
        if notes:
            print(k, "; ".join(notes))
        if not any("larger" in n or "SMALLER" in n or "DIFFERENT" in n for n in notes):
            same += 1
    print(f"rows with every figure within {rel:g} relative: {same} / {len(a)}; larger figures {larger}, "
          f"smaller or different {bad}")
    return 0 if bad == 0 else 1


def compare(a_path: str, b_path: str) -> int:
    a, b = json.loads(Path(a_path).read_text()), json.loads(Path(b_path).read_text())
    same = 0
    for k, ra in a.items():
        rb = b.get(k)
        if rb is None:
            print("missing", k)
            continue
        diff = {f: (ra[f], rb.get(f)) for f in ra if not f.startswith("_") and "second" not in f and ra[f] != rb.get(f)}
        if diff:
            print(k, diff)
        else:
            same += 1
    print(f"identical rows {same} / {len(a)}")
    return 0 if same == len(a) else 1


if __name__ == "__main__":
    cmd, *args = sys.argv[1:]
    if cmd == "meshes":
        meshes(*args)
    elif cmd == "figures":
        figures(*args)
    elif cmd == "compare":
        if len(args) == 4 and args[2] == "--rel":
            sys.exit(compare_rel(args[0], args[1], float(args[3])))
        sys.exit(compare(*args))
    else:
        sys.exit(__doc__)

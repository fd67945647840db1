"""Interop costs: in-memory Open CASCADE shapes and .brep files against STEP; CAE mesh formats through meshio.

Part 1, for a few shared STEP files: ``read_shell(step)`` (child process: read, convert, copy), the same
shape written as an Open CASCADE ``.brep`` and read with ``read_shell(brep)``, and ``from_occ(shape)`` on
the shape already in memory (conversion only, in process). Part 2: a mesh of ~N triangles (the
bspline_box sample tessellated finely) written and read back in every mesh format, with the file size
and whether vertices and triangles came back exactly (max coordinate change otherwise). Best of REPEATS.

Usage: python benchmarks/interop_io.py [--json out.json] [--triangles N]
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from trimsurf import io
from trimsurf.errors import TrimsurfWarning

REPEATS = 2
DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "cad"
FILES = ("gmsh__t20_data.step", "occt__screw.step", "gmsh__U_Joint_2.stp", "occt__linkrods.step")


def best(fn, repeats: int = REPEATS) -> tuple[float, object]:
    times, out = [], None
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return min(times), out


def occ_shape(path: Path):
    from OCP.STEPControl import STEPControl_Reader

    with io._occ.quiet_occ():
        reader = STEPControl_Reader()
        reader.ReadFile(str(path))
        reader.TransferRoots()
        return reader.OneShape()


def cad_rows(folder: Path) -> list[dict]:
    from OCP.BRepTools import BRepTools

    io.read_shell(DATA / FILES[0])  # start the reader server outside the timings
    rows = []
    for name in FILES:
        step = DATA / name
        shape = occ_shape(step)
        brep = folder / (step.stem + ".brep")
        with io._occ.quiet_occ():
            BRepTools.Write_s(shape, str(brep))
        t_step, shell = best(lambda: io.read_shell(step))
        t_brep, from_brep = best(lambda: io.read_shell(brep))
        t_mem, from_mem = best(lambda: io.from_occ(shape))
        rows.append({"file": name, "faces": len(shell.faces), "step_MB": step.stat().st_size / 1e6,
                     "brep_MB": brep.stat().st_size / 1e6, "read_step_s": t_step, "read_brep_s": t_brep,
                     "from_occ_s": t_mem, "same_faces": len(from_brep.faces) == len(from_mem.faces) == len(shell.faces)})
    return rows


def mesh_rows(folder: Path, n_triangles: int) -> list[dict]:
    from trimsurf.samples import build_sample
    from trimsurf.tessellate import tessellate_shell

    shell = build_sample("bspline_box")
    d = shell.diagonal()
    edge = 0.03 * d * (7668 / n_triangles) ** 0.5  # 7,668 triangles at the default max edge 3e-2 d
    mesh = tessellate_shell(shell, max_edge=edge, measure=False).mesh
    rows = []
    for suffix in io.MESH_SUFFIXES:
        path = folder / f"m{suffix}"
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", TrimsurfWarning)  # Nastran's 16-column fields
            t_w, _ = best(lambda: io.write_mesh(mesh, path))
        t_r, back = best(lambda: io.read_mesh(path))
        same_t = back.triangles.shape == mesh.triangles.shape and np.array_equal(back.triangles, mesh.triangles)
        moved = float(np.abs(back.vertices - mesh.vertices).max()) if back.vertices.shape == mesh.vertices.shape \
            else float("nan")
        rows.append({"format": suffix, "triangles": mesh.n_triangles, "MB": path.stat().st_size / 1e6,
                     "write_s": t_w, "read_s": t_r, "triangles_exact": bool(same_t),
                     "max_moved_rel": moved / d})
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=Path)
    parser.add_argument("--triangles", type=int, default=100_000)
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="trimsurf-interop-") as tmp:
        cad = cad_rows(Path(tmp))
        meshes = mesh_rows(Path(tmp), args.triangles)
    print("| file | faces | STEP MB | BREP MB | read_shell(step) s | read_shell(brep) s | from_occ(shape) s | same faces |")
    print("|---|---:|---:|---:|---:|---:|---:|---|")
    for r in cad:
        print(f"| {r['file']} | {r['faces']} | {r['step_MB']:.2f} | {r['brep_MB']:.2f} | {r['read_step_s']:.2f} | "
              f"{r['read_brep_s']:.2f} | {r['from_occ_s']:.2f} | {'yes' if r['same_faces'] else 'NO'} |")
    print()
    print("| format | triangles | MB | write s | read s | triangles exact | max vertex change / diag |")
    print("|---|---:|---:|---:|---:|---|---:|")
    for r in meshes:
        print(f"| {r['format']} | {r['triangles']} | {r['MB']:.2f} | {r['write_s']:.2f} | {r['read_s']:.2f} | "
              f"{'yes' if r['triangles_exact'] else 'NO'} | {r['max_moved_rel']:.2g} |")
    if args.json:
        args.json.write_text(json.dumps({"cad": cad, "meshes": meshes}, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

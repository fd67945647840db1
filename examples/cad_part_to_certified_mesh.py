"""A CAD part built in Python -> trimsurf Shell in memory -> mesh whose guarantees are measured -> CAE file.

    python examples/cad_part_to_certified_mesh.py part.vtu

Builds a box with filleted edges with CadQuery when it is installed
(``cq.Workplane().box(30, 20, 10).edges().fillet(2)``), else with plain OCP
(BRepPrimAPI_MakeBox + BRepFilletAPI_MakeFillet; CadQuery 2.8 needs
cadquery-ocp < 8, which trimsurf does not use), converts it with
`trimsurf.io.from_occ` (no STEP file in between), tessellates it and checks
what the tessellation paper promises: every triangle within the tolerance of
the exact faces, watertight, consistently oriented, no flipped triangle.
The mesh is written by suffix (.vtu, .msh, .inp, .bdf, .ply, ...), read back
and compared. Exit status 1 when a check fails.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

import trimsurf.io as tio
from trimsurf.tessellate import tessellate_shell


def build_part():
    """The part: a CadQuery Workplane if CadQuery imports, else an OCP TopoDS_Shape (both go to from_occ)."""
    try:
        import cadquery as cq
    except ImportError:
        cq = None
    if cq is not None:
        return cq.Workplane().box(30, 20, 10).edges().fillet(2)
    from OCP.BRepFilletAPI import BRepFilletAPI_MakeFillet
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    box = BRepPrimAPI_MakeBox(30.0, 20.0, 10.0).Shape()
    fillet = BRepFilletAPI_MakeFillet(box)
    edges = TopExp_Explorer(box, TopAbs_EDGE)
    while edges.More():
        fillet.Add(2.0, TopoDS.Edge(edges.Current()))
        edges.Next()
    return fillet.Shape()


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", nargs="?", type=Path, default=Path("part.vtu"), help="mesh file, format by suffix")
    args = parser.parse_args(argv)
    shell = tio.from_occ(build_part(), name="filleted box")
    result = tessellate_shell(shell)
    mesh, rep = result.mesh, result.report
    checks = {
        "within tolerance": rep["max_deviation"] <= rep["tolerance"],
        "watertight": mesh.is_watertight(),
        "oriented": mesh.is_consistently_oriented(),
        "no flipped triangles": rep["flipped"] == 0,
        "no failed faces": result.ok,
    }
    print(f"{shell.name}: {len(shell.faces)} faces, {mesh.n_triangles} triangles, max deviation "
          f"{rep['max_deviation']:.3g} <= tolerance {rep['tolerance']:.3g} (sampled and projected)")
    tio.write_mesh(mesh, args.out)
    back = tio.read_mesh(args.out)
    moved = float(np.abs(back.vertices - mesh.vertices).max())
    checks["file read back"] = np.array_equal(back.triangles, mesh.triangles) and moved <= 1e-9 * mesh.diagonal()
    for name, ok in checks.items():
        print(f"  {'ok  ' if ok else 'FAIL'} {name}")
    print(f"wrote {args.out} (vertices moved by {moved:.3g} on the way)")
    return 0 if all(checks.values()) else 1


if __name__ == "__main__":
    sys.exit(main())

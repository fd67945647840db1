"""A scanned surface mesh with holes -> one trimmed NURBS face -> STEP.

    python examples/scan_to_trimmed_nurbs.py scan.ply -o face.step

Without a mesh file, the embedded holed sheet (a curved sheet with two
holes) is used. The fit follows the mesh-to-trimmed-NURBS paper: parameters
by a manifold embedding, a NURBS back-map, the mesh boundaries as trim loops.
Prints the sampled Hausdorff distance between mesh and face; writes STEP and
reads it back.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import trimsurf.io as tio
from trimsurf.fit import fit_quality, fit_trimmed_face
from trimsurf.model import Shell


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mesh", nargs="?", type=Path, help="disk-like mesh with holes (default: a sample)")
    parser.add_argument("-o", "--out", dest="step", type=Path, default=Path("face.step"), help="STEP file to write")
    parser.add_argument("--embed", default="lscm", help="forward map: hlle, isomap, laplacian, lscm, harmonic")
    args = parser.parse_args(argv)
    if args.mesh is None:
        from trimsurf.samples import holed_sheet

        mesh, name = holed_sheet(max_area=600.0), "holed_sheet"
    else:
        mesh, name = tio.read_mesh(args.mesh), args.mesh.stem
    result = fit_trimmed_face(mesh, embed_method=args.embed, name=name)
    quality = fit_quality(result, mesh)
    face = result.face
    print(f"{name}: {mesh.n_vertices} vertices -> NURBS {face.surface.control_points.shape[0]} x "
          f"{face.surface.control_points.shape[1]} control points, {len(face.loops)} trim loops; Hausdorff "
          f"{quality.hausdorff:.3g} ({quality.hausdorff_rel:.2e} of the diagonal, sampled), flipped "
          f"{result.embedding.n_flipped}")
    tio.write_shell(Shell.from_faces([face], name=name), args.step)
    back = tio.read_shell(args.step)
    print(f"wrote {args.step}: {len(back.faces)} face, {len(back.faces[0].loops)} loops read back")
    return 0 if len(back.faces[0].loops) == len(face.loops) and result.embedding.n_flipped == 0 else 1


if __name__ == "__main__":
    sys.exit(main())

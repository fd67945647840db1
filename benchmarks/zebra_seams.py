"""trimsurf.viz: which seams between CAD faces the zebra shades as smooth, against the exact normals.

`unshare_faces` (the mesh zebra and highlight pictures, PNG and web page) shares a seam vertex between
two faces where the faces join smoothly and duplicates it at creases (per-face normals). It decides from
the mesh alone (`_seam_edges`: the seam's dihedral angle against the triangles around it). Here each
file is tessellated with `tessellate_shell`'s defaults and every seam edge of the joined mesh is
classified by the exact surface normals of its two faces at its ends (the smaller angle of the two ends,
so a singular corner does not count as a crease): G1 = the faces' normals agree within 1 degree,
crease = they differ by more than 5 degrees. A G1 seam that is split draws a stripe break that is not in
the surface (the false alarm); a crease that is shared is blended over one ring of triangles.

Usage: python benchmarks/zebra_seams.py [FILE ...]   (default: the files below from ../shared/data/cad)
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from trimsurf import io
from trimsurf.cli.view import mesh_with_face_uv
from trimsurf.tessellate import tessellate_shell
from trimsurf.viz._exact import _seam_edges, seam_exact_angles

CAD = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "cad"
FILES = ("occt__screw.step", "gmsh__t20_data.step", "occt__linkrods.step", "occtpr946__ec_soapbox-A.stp",
         "gmsh__U_Joint_2.stp", "gmsh__SampleCrankshaft4A.stp", "occtpr946__trj5_k1-pe-214.stp")


def seam_classes(path: Path) -> dict:
    shell = io.read_shell(path)
    res = tessellate_shell(shell)
    mesh = res.mesh
    ends, smooth = seam_exact_angles(mesh, mesh_with_face_uv(res), shell)
    _, _, ta, tb, _ = _seam_edges(mesh)
    exact = np.minimum(*ends)  # NaN where an end was not found
    tn = mesh.triangle_normals()
    tn /= np.linalg.norm(tn, axis=1, keepdims=True)
    dihedral = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", tn[ta], tn[tb]), -1, 1)))
    found = np.isfinite(exact)
    g1, crease = found & (exact < 1.0), found & (exact > 5.0)
    blended = smooth & crease
    return {"file": path.name, "seams": len(ta), "found": int(found.sum()), "g1": int(g1.sum()),
            "g1_shared": int((smooth & g1).sum()), "crease": int(crease.sum()), "crease_blended": int(blended.sum()),
            "blended_max_exact_deg": float(exact[blended].max()) if blended.any() else 0.0,
            "blended_max_mesh_deg": float(dihedral[blended].max()) if blended.any() else 0.0}


def main(argv: list[str]) -> None:
    paths = [Path(p) for p in argv] or [CAD / f for f in FILES]
    print(f"{'file':32s} {'seams':>6s} {'found':>6s} {'G1':>6s} {'G1 shared':>9s} {'crease':>6s} "
          f"{'blended':>7s} {'max exact':>9s} {'max mesh':>8s} {'s':>5s}")
    for p in paths:
        t0 = time.perf_counter()
        r = seam_classes(p)
        print(f"{r['file'][:32]:32s} {r['seams']:6d} {r['found']:6d} {r['g1']:6d} {r['g1_shared']:9d} "
              f"{r['crease']:6d} {r['crease_blended']:7d} {r['blended_max_exact_deg']:9.1f} "
              f"{r['blended_max_mesh_deg']:8.1f} {time.perf_counter() - t0:5.1f}", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])

"""The flip test with the deviation's centroid feet against a fresh projection of the corners' mean (issue 17, item 2).

``trimsurf tessellate`` used to measure the flips of the file read back by projecting every triangle's
centroid (the mean of its corners) afresh with the full seed search; the in-memory measurement takes the
foot of the (1/3, 1/3, 1/3) node the deviation already projected (an einsum of the corners: the same point
up to rounding). Now the read-back check reuses the in-memory figure when the file holds exactly the
measured mesh (`tessellate.measure.figures_of_same_mesh`). This script checks, per triangle of every
pickled mesh in DIR (``benchmarks/measure_same.py meshes DIR``), that both feet give the same sign of
(triangle normal) . (outward surface normal), and prints how many feet differ at all and the smallest
|cos| between the two normals (the margin a rounding-level change of the foot would have to cross).

Usage: python benchmarks/flip_feet.py DIR
"""

from __future__ import annotations

import pickle
import sys
from pathlib import Path

import numpy as np


def main(folder: str) -> None:
    from trimsurf.quality import deviation as dv
    from trimsurf.quality.sampling import as_face

    total = differ = 0
    for f in sorted(Path(folder).iterdir()):
        shell, res = pickle.loads(f.read_bytes())
        m = res.mesh
        _, states = dv._shell_deviation(m, shell, density=3, n_domain=32, two_sided=True, tol_rel=1e-10,
                                        refine=0.01, skip=True)
        n_sign = n_feet = 0
        min_cos = np.inf
        for i in np.unique(m.face_id).tolist():
            sub = m.submesh(m.face_id == i)
            face = as_face(shell.faces[i])
            fresh = dv.project_to_face(sub.vertices[sub.triangles].mean(axis=1), face, tol_rel=1e-10).uv
            mem = states[i].centroid_uv
            n_feet += int(np.count_nonzero(np.any(fresh != mem, axis=1)))
            tn = sub.triangle_normals()
            ns = face.oriented_normals(fresh)
            a = np.sign(np.einsum("ij,ij->i", tn, face.oriented_normals(mem)))
            b = np.sign(np.einsum("ij,ij->i", tn, ns))
            n_sign += int(np.count_nonzero(a != b))
            cos = np.einsum("ij,ij->i", tn, ns) / np.linalg.norm(tn, axis=1) / np.linalg.norm(ns, axis=1)
            min_cos = min(min_cos, float(np.nanmin(np.abs(cos))))
        total += m.n_triangles
        differ += n_sign
        print(f"{f.stem:45s} triangles {m.n_triangles:6d} feet differing {n_feet:6d} signs differing {n_sign} "
              f"min |cos| {min_cos:.3f}", flush=True)
    print(f"total: {total} triangles, {differ} signs differ")


if __name__ == "__main__":
    main(sys.argv[1])

"""Same loose meshes? Hash what `tessellate_shell(mode="loose")` makes of real files (issue 17).

Per model x setting (tol: eps = 1e-3 of the diagonal, max edge = the diagonal; paper: max edge 3 %), a
SHA-256 of the merged mesh's vertices, triangles, face_id, the quads, every face mesh (vertices,
triangles, uv) and the report without its seconds, and the meshing CPU (best of 3). Compare two trees
by running it with each on PYTHONPATH and diffing the hash columns (mesh_identity.py covers the default,
conforming, mode):

    PYTHONPATH=/tmp/old/src python benchmarks/loose_identity.py > old.txt
    PYTHONPATH=src python benchmarks/loose_identity.py > new.txt
    diff <(cut -c1-44 old.txt) <(cut -c1-44 new.txt)

Usage: python benchmarks/loose_identity.py [models, comma-separated name parts]
"""
import hashlib, json, sys, time
from pathlib import Path
import numpy as np
from trimsurf.io import read_shell
from trimsurf.tessellate import tessellate_shell
DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "cad"
if not DATA.exists():
    DATA = Path("/work/shared/data/cad")
models = (sys.argv[1] if len(sys.argv) > 1 else
          "featuretype,t20,soapbox,abc_0_13,turbine,U_Joint,screw,Crank,wing,bearing").split(",")
for key in models:
    name = next(p for p in sorted(DATA.iterdir()) if key in p.name)
    shell = read_shell(name); d = shell.diagonal()
    for setting, h in (("tol", d), ("paper", 0.03 * d)):
        res = tessellate_shell(shell, tolerance=1e-3 * d, max_edge=h, measure=False, mode="loose")
        best = 1e9
        for _ in range(3):
            t = time.process_time(); tessellate_shell(shell, tolerance=1e-3 * d, max_edge=h, measure=False, mode="loose"); best = min(best, time.process_time() - t)
        hs = hashlib.sha256()
        for a in (res.mesh.vertices, res.mesh.triangles, res.mesh.face_id, res.quads):
            hs.update(np.ascontiguousarray(a).tobytes()); hs.update(str(a.dtype).encode()); hs.update(str(a.shape).encode())
        rep = {k: v for k, v in res.report.items() if not k.startswith("seconds")}
        hs.update(json.dumps(rep, sort_keys=True, default=str).encode())
        for fm in res.face_meshes:
            if fm is not None:
                hs.update(fm.vertices.tobytes()); hs.update(fm.triangles.tobytes()); hs.update(fm.uv.tobytes())
        print(f"{key:12s} {setting:5s} {res.mesh.n_triangles:7d} {hs.hexdigest()[:16]} {best:.4f}", flush=True)

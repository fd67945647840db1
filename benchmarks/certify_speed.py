"""Certifying the shared CAD models: faces certified per second, where the time goes, against Open CASCADE.

For every STEP file in ../shared/data/cad (or those given): ``trimsurf.certify.certify_shell``
(adaptive boundary sampling of eps = b_k - F(p_k) per edge, Whitney extension, normal bound,
Volino-Thalmann test over all close face pairs) and, on the same model, the checks Open CASCADE
offers for a B-rep: ``BRepCheck_Analyzer`` (topology and geometry validity, including
same-parameter consistency of p-curves and edge curves) plus ``BOPAlgo_ArgumentAnalyzer`` with
self-interference on (faces meeting other than at shared edges). The ratio is trimsurf / OCCT
time. Open CASCADE answers valid or not; trimsurf also gives per-face bounds, so the figures
are of different strength: the ratio says what the certificate costs, not who is faster at
the same job.

"Where time goes": the four stages of certify_shell (boundary sampling with the gap
refinement of shared edges, per-face Whitney and rigorous normal bound, intersections, the
measurement of the edge gaps at 10,000 random points per shared edge) and, with --profile,
the five functions with most own time. Per model: faces certified, faces whose normal bound is
rigorous (control nets), shared edges whose gap bound is within the point tolerance (the
file's; 1e-6 of the diagonal where it states none), the largest gap measured and bounded.

Usage: python benchmarks/certify_speed.py [--json out.json] [--profile] [--tolerance file|diagonal] [FILES...]
"""

from __future__ import annotations

import argparse
import cProfile
import json
import pstats
import sys
import time
from pathlib import Path

from trimsurf import io
from trimsurf.certify import certify_shell, file_point_tolerance

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "cad"
DEFAULT = ["gmsh__t20_data.step", "occt__screw.step", "gmsh__wrenchnut.stp", "occtpr946__trj5_k1-pe-214.stp",
           "gmsh__U_Joint_2.stp", "gmsh__SampleCrankshaft4A.stp"]


def occ_check(path: Path) -> tuple[float, bool, bool, int]:
    """Time of BRepCheck_Analyzer + BOPAlgo_ArgumentAnalyzer (self-interference) on the file's shape."""
    from OCP.BOPAlgo import BOPAlgo_ArgumentAnalyzer
    from OCP.BRepCheck import BRepCheck_Analyzer

    from trimsurf.errors import StepReadError
    from trimsurf.io._occ import map_topology, read_shape

    shape = read_shape(path, "STEP", StepReadError)     # the file's own shape, as Open CASCADE reads it
    n = len(map_topology(shape).faces)
    t = time.perf_counter()
    valid = BRepCheck_Analyzer(shape).IsValid()
    ana = BOPAlgo_ArgumentAnalyzer()
    ana.SetShape1(shape)
    ana.SelfInterMode = True          # a property in OCP
    ana.Perform()
    free = not ana.HasFaulty()
    return time.perf_counter() - t, bool(valid), bool(free), n


def run_one(path: Path, profile: bool, tolerance: str) -> dict:
    shell = io.read_shell(path)
    tol = file_point_tolerance(path) if tolerance == "file" else None     # None: 1e-6 of the diagonal
    prof = cProfile.Profile() if profile else None
    t = time.perf_counter()
    if prof:
        prof.enable()
    cert = certify_shell(shell, point_tolerance=tol)
    if prof:
        prof.disable()
    elapsed = time.perf_counter() - t
    occ_s, occ_valid, occ_free, occ_faces = occ_check(path)
    row = {"file": path.name, "faces": len(shell.faces), "faces_certified": cert.n_faces_certified,
           "pairs_tested": len(cert.pairs), "pairs_excluded": cert.n_pairs_excluded,
           "adjacent_pairs": sum(p.adjacent for p in cert.pairs),
           "adjacent_excluded": sum(p.adjacent and p.intersections_excluded for p in cert.pairs),
           "max_discrepancy": max(f.max_discrepancy for f in cert.faces),
           "faces_rigorous": sum(f.bound_kind == "rigorous" for f in cert.faces),
           "shared_edges": len(cert.edges),
           "edges_within_tolerance": sum(e["gap_bound"] <= e["tolerance"] for e in cert.edges),
           "edge_gap_max": cert.edge_gap_max, "edge_gap_bound": cert.edge_gap_bound,
           "point_tolerance": cert.point_tolerance, "diagonal": cert.diagonal,
           "edge_samples": int(sum(e["n_samples"] for e in cert.edges)),
           "certify_s": elapsed, "faces_per_s": len(shell.faces) / elapsed,
           "stages_s": {k: v for k, v in cert.timings_s.items() if k != "total"},
           "occ_check_s": occ_s, "occ_faces_per_s": occ_faces / occ_s if occ_s > 0 else None,
           "occ_valid": occ_valid, "occ_no_self_interference": occ_free, "ratio_trimsurf_over_occ": elapsed / occ_s}
    if prof:
        st = pstats.Stats(prof)
        top = sorted(st.stats.items(), key=lambda kv: -kv[1][2])[:5]
        row["top_functions"] = [{"function": f"{Path(k[0]).name}:{k[2]}", "own_s": v[2]} for k, v in top]
    return row


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("files", nargs="*", type=Path, help="STEP files (default: six of the shared models)")
    parser.add_argument("--json", type=Path, help="also write the rows as JSON")
    parser.add_argument("--profile", action="store_true", help="profile certify_shell (top 5 functions by own time)")
    parser.add_argument("--tolerance", choices=("file", "diagonal"), default="file",
                        help="point tolerance for the edge gaps: the file's (default; 1e-6 of the diagonal where it "
                             "states none) or 1e-6 of the diagonal")
    args = parser.parse_args(argv)
    files = args.files or [DATA / f for f in DEFAULT]
    rows = []
    head = (f"{'file':34} {'faces':>5} {'cert':>5} {'rig':>4} {'adj ok':>9} {'edges ok':>9} {'tol':>8} "
            f"{'gap meas':>8} {'gap bnd':>8} {'certify s':>9} {'sample/face/VT/gap s':>23} {'OCCT s':>7} "
            f"{'ratio':>6} {'OCCT valid/free':>15}")
    print(head)
    for path in files:
        r = run_one(path, args.profile, args.tolerance)
        rows.append(r)
        st = r["stages_s"]
        gm = r["edge_gap_max"] if r["edge_gap_max"] is not None else float("nan")
        print(f"{r['file']:34} {r['faces']:5d} {r['faces_certified']:5d} {r['faces_rigorous']:4d} "
              f"{r['adjacent_excluded']:4d}/{r['adjacent_pairs']:<4d} "
              f"{r['edges_within_tolerance']:4d}/{r['shared_edges']:<4d} {r['point_tolerance']:8.2g} "
              f"{gm:8.2g} {r['edge_gap_bound']:8.2g} {r['certify_s']:9.2f} "
              f"{st['boundary_sampling']:5.1f}/{st['faces']:5.1f}/{st['intersections']:5.1f}/"
              f"{st['gap_measurement']:5.1f} {r['occ_check_s']:7.2f} {r['ratio_trimsurf_over_occ']:6.1f} "
              f"{str(r['occ_valid']) + '/' + str(r['occ_no_self_interference']):>15}", flush=True)
        for t in r.get("top_functions", []):
            print(f"      {t['own_s']:7.2f} s  {t['function']}")
    tf = sum(r["faces"] for r in rows)
    ts = sum(r["certify_s"] for r in rows)
    to = sum(r["occ_check_s"] for r in rows)
    print(f"total: {tf} faces, {sum(r['faces_certified'] for r in rows)} certified "
          f"({sum(r['faces_rigorous'] for r in rows)} with a rigorous normal bound), "
          f"{sum(r['edges_within_tolerance'] for r in rows)}/{sum(r['shared_edges'] for r in rows)} shared edges "
          f"within the point tolerance, {ts:.1f} s "
          f"({tf / ts:.1f} faces/s); Open CASCADE checks {to:.1f} s ({tf / to:.1f} faces/s); ratio {ts / to:.1f}")
    if args.json:
        args.json.write_text(json.dumps({"rows": rows, "total_faces": tf, "total_s": ts, "occ_total_s": to},
                                        indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Certify a shell: Whitney perturbation of every face, normal bounds, no extraneous intersections."""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..errors import InputError
from ..model import Shell, TriMesh
from ..quality._results import ResultMixin, jsonable
from ..tolerance import Tolerance
from ._boundary import sample_boundaries
from ._face import FaceCertificate, face_certificate
from ._gap import measure_edge_gaps
from ._intersect import build_hierarchy, excluded_pair, excluded_self
from ._mesh import well_defined_mesh
from ._perturb import PerturbedFace

__all__ = ["PairCertificate", "ShellCertificate", "certify_shell", "perturb_shell"]


@dataclass(frozen=True, eq=False)
class PairCertificate(ResultMixin):
    """Whether two faces can meet other than along their common edges and vertices.

    Attributes
    ----------
    faces : (int, int)
    adjacent : bool
        The faces share an edge.
    shared_edges : list of int
    intersections_excluded : bool
        The Volino-Thalmann test excludes every extraneous intersection.
    where : list of dict
        Where it could not (faces, (u, v) boxes of the two pieces, a point in space, reason).
    """

    faces: tuple
    adjacent: bool
    shared_edges: list
    intersections_excluded: bool
    where: list


@dataclass(eq=False)
class ShellCertificate:
    """The result of `certify_shell`.

    Attributes
    ----------
    name : str
    faces : list of FaceCertificate
    pairs : list of PairCertificate
        Every adjacent pair, and every other pair whose boxes overlap.
    perturbed : list of PerturbedFace
        The well-defined faces G = F + a (evaluable anywhere in the face).
    diagonal : float
    settings : dict
    timings_s : dict
    """

    name: str
    faces: list
    pairs: list
    perturbed: list
    diagonal: float
    settings: dict
    timings_s: dict
    _edges: list = field(default=None, repr=False)
    edges: list = field(default_factory=list)
    point_tolerance: float = 0.0

    @property
    def edge_gap_bound(self) -> float:
        """Largest rigorous bound of the gap between the perturbed faces over all shared edges."""
        return max((e["gap_bound"] for e in self.edges), default=0.0)

    @property
    def edge_gap_max(self) -> float | None:
        """Largest gap measured at random points of the shared edges (None when not measured)."""
        vals = [e["gap_max"] for e in self.edges if e.get("gap_max") is not None]
        return max(vals) if vals else None

    @property
    def n_faces_certified(self) -> int:
        return sum(1 for f in self.faces if f.certified)

    @property
    def n_pairs_excluded(self) -> int:
        return sum(1 for p in self.pairs if p.intersections_excluded)

    @property
    def certified(self) -> bool:
        return (all(f.certified for f in self.faces) and all(p.intersections_excluded for p in self.pairs)
                and all(e["gap_bound"] <= e["tolerance"] for e in self.edges))

    def problems(self) -> list[str]:
        """One line per face or pair that is not certified, saying where."""
        out = []
        for f in self.faces:
            out += list(f.problems)
        for e in self.edges:
            if not np.isfinite(e["gap_bound"]):
                out.append(f"edge {e['shell_edge']} (faces {', '.join(map(str, e['faces']))}): no bound on the gap "
                           "between the perturbed faces (a face's trim polygon crosses itself, or a "
                           "sample lies outside a surface's domain)")
            elif e["gap_bound"] > e["tolerance"]:
                out.append(f"edge {e['shell_edge']} (faces {', '.join(map(str, e['faces']))}): the perturbed faces may be "
                           f"up to {e['gap_bound']:.3g} apart between samples, above the point tolerance "
                           f"{e['tolerance']:.3g}")
        for p in self.pairs:
            if not p.intersections_excluded:
                w = p.where[0] if p.where else None
                if w and "point" in w:
                    at = (f" near ({w['point'][0]:.6g}, {w['point'][1]:.6g}, {w['point'][2]:.6g}), uv boxes "
                          f"{_box(w['uv_box_a'])} / {_box(w['uv_box_b'])}: {w['reason']}")
                else:
                    at = f": {w['reason']}" if w else ""
                kind = "self-intersection" if p.faces[0] == p.faces[1] else "extraneous intersection"
                out.append(f"faces {p.faces[0]} and {p.faces[1]}: {kind} not excluded{at}")
        return out

    def summary(self) -> str:
        """One line: faces certified, pairs excluded, worst normal bound, largest discrepancy."""
        worst = max((f.normal_bound_deg for f in self.faces), default=0.0)
        disc = max((f.max_discrepancy for f in self.faces), default=0.0)
        adj = [p for p in self.pairs if p.adjacent]
        return (f"{self.name}: {'CERTIFIED' if self.certified else 'NOT CERTIFIED'}: "
                f"{self.n_faces_certified}/{len(self.faces)} faces certified, "
                f"{sum(p.intersections_excluded for p in adj)}/{len(adj)} adjacent pairs and "
                f"{sum(p.intersections_excluded for p in self.pairs if not p.adjacent)}/"
                f"{sum(1 for p in self.pairs if not p.adjacent)} other close pairs free of extraneous intersections; "
                f"max discrepancy {disc:.3g}, worst normal bound {worst:.3g} deg; shared edges meet within "
                f"{self.edge_gap_bound:.3g} (point tolerance {self.point_tolerance:.3g})")

    def as_dict(self) -> dict:
        """The JSON report (field names of the issue: max_discrepancy, lipschitz, normal_bound_deg, certified)."""
        return jsonable({"name": self.name, "certified": self.certified, "summary": self.summary(),
                         "n_faces": len(self.faces), "n_faces_certified": self.n_faces_certified,
                         "n_pairs": len(self.pairs), "n_pairs_excluded": self.n_pairs_excluded,
                         "diagonal": self.diagonal, "point_tolerance": self.point_tolerance,
                         "edge_gap_bound": self.edge_gap_bound, "edge_gap_max": self.edge_gap_max,
                         "n_edges_within_tolerance": sum(e["gap_bound"] <= e["tolerance"] for e in self.edges),
                         "edges": self.edges, "settings": self.settings, "timings_s": self.timings_s,
                         "faces": [f.as_dict(arrays=True) for f in self.faces],
                         "pairs": [p.as_dict(arrays=True) for p in self.pairs],
                         "problems": self.problems()})

    def to_table(self) -> list[dict]:
        """The report as a one-row table (a list with one flat dict) that ``pandas.DataFrame`` accepts."""
        from ..viz._notebook import report_table  # viz is a higher layer: imported on use only
        return report_table(self)

    def _repr_html_(self) -> str:
        """Jupyter: the interactive viewer inline (offline) and the report's key figures."""
        from ..viz._notebook import repr_html
        return repr_html(self)

    def well_defined_mesh(self, *, n_triangles_per_face: int = 400, min_angle_deg: float = 25.0) -> TriMesh:
        """The perturbed faces tessellated so that they meet exactly along b_k (watertight by construction)."""
        return well_defined_mesh(self.perturbed, self._edges, n_triangles_per_face=n_triangles_per_face,
                                 min_angle_deg=min_angle_deg)

    def validate_with_mesh(self, *, n_triangles_per_face: int = 400) -> dict:
        """Independent check: exact triangle-triangle intersections on a tessellation of the well-defined shell.

        Returns
        -------
        dict
            n_triangles, watertight, n_boundary_loops, n_intersecting_triangle_pairs (exact test, eps = 0
            for triangles without a common vertex), n_unconfirmed_hits (contacts closer than 1e-12 of the
            diagonal that the exact test rejects), intersecting_face_pairs (list of [a, b] with
            intersecting triangles, a == b for a face meeting itself), contradictions (pairs certified free
            of extraneous intersections that the mesh shows intersecting; must be empty).
        """
        from ..quality import self_intersections, topology_report, triangles_intersect

        mesh = self.well_defined_mesh(n_triangles_per_face=n_triangles_per_face)
        tol = Tolerance(point=1e-12 * max(self.diagonal, 1e-300), angle_rad=1e-9)
        si = self_intersections(mesh, tol=tol)
        pairs = si.pairs
        if len(pairs):
            # re-test vertex-disjoint hits with eps = 0 (both orders): with eps = 1e-12 diag the test also
            # counts near-contacts, e.g. two triangles on either side of a sliver whose height is below eps
            # (dense boundary samples near corners); those are reported as n_unconfirmed_hits
            ta, tb = mesh.triangles[pairs[:, 0]], mesh.triangles[pairs[:, 1]]
            disjoint = ~(ta[:, :, None] == tb[:, None, :]).any(axis=(1, 2))
            pa, pb = mesh.vertices[ta], mesh.vertices[tb]
            confirm = triangles_intersect(pa, pb) | triangles_intersect(pb, pa)
            keep = ~disjoint | confirm
            n_unconfirmed = int((~keep).sum())
            pairs = pairs[keep]
        else:
            n_unconfirmed = 0
        fp = np.sort(mesh.face_id[pairs], axis=1) if len(pairs) else np.zeros((0, 2), dtype=np.int64)
        hit = sorted({(int(a), int(b)) for a, b in fp})
        excluded = {tuple(sorted(p.faces)) for p in self.pairs if p.intersections_excluded}
        excluded |= {(f.face, f.face) for f in self.faces if f.certified}
        topo = topology_report(mesh)
        return {"n_triangles": mesh.n_triangles, "watertight": topo.is_watertight,
                "n_boundary_loops": topo.n_boundary_loops,
                "n_intersecting_triangle_pairs": int(len(pairs)), "n_unconfirmed_hits": n_unconfirmed,
                "intersecting_face_pairs": [list(p) for p in hit],
                "contradictions": [list(p) for p in hit if p in excluded]}


def _box(b) -> str:
    return f"[{b[0]:.4g},{b[1]:.4g}]x[{b[2]:.4g},{b[3]:.4g}]"


def perturb_shell(shell: Shell, *, rtol: float = 1e-2, max_chord: float | None = None) -> list[PerturbedFace]:
    """The perturbed patches G_f = F_f + a_f of every face (Sec. 3.1), without certification.

    Parameters
    ----------
    shell : Shell
    rtol : float
        Refinement stops when the sampled Lipschitz constants change by less than this.
    max_chord : float or None
        Largest spacing of boundary samples in space (default 1/100 of the diagonal).

    Returns
    -------
    list of PerturbedFace
    """
    shell = _check_shell(shell)
    chord = shell.diagonal() / 100.0 if max_chord is None else float(max_chord)
    bounds, _, _ = sample_boundaries(shell, rtol=rtol, max_chord=chord)
    return [PerturbedFace(shell.faces[b.face], b, b.lipschitz) for b in bounds]


def _check_shell(shell) -> Shell:
    if not isinstance(shell, Shell):
        raise InputError(f"certify needs a trimsurf.model.Shell; got {type(shell).__name__}")
    if not shell.faces:
        raise InputError(f"{shell.name or 'shell'}: no faces to certify")
    return shell


def certify_shell(shell: Shell, *, rtol: float = 1e-2, max_chord: float | None = None, n_domain: int = 40,
                  max_normal_angle_deg: float = 90.0, intersections: bool = True, budget: int = 20000,
                  progress: Callable[[str, int], None] | None = None, pairing: str = "surface",
                  point_tolerance: float | None = None, gap_samples: int = 10000) -> ShellCertificate:
    """Make a trimmed B-rep well defined and certify it (whitney-well-definition.txt, Secs. 3-4).

    Parameters
    ----------
    shell : Shell
    rtol : float
        Adaptive boundary sampling stops when the Lipschitz constants change by less than this (relative).
    max_chord : float or None
        Largest spacing of boundary samples in space (default 1/100 of the bounding-box diagonal).
    n_domain : int
        Grid points per direction for the normal bound and the l <= u check over each face.
    max_normal_angle_deg : float
        A face is certified when its normal bound is below this (and l <= u, and no self-intersection).
    intersections : bool
        Run the Volino-Thalmann test (pairs of faces and each face with itself).
    budget : int
        Node tests per face pair before the test gives up (reported as not excluded).
    progress : callable or None
        ``progress(stage, n)`` after each unit of work (stage "faces" or "pairs").
    pairing : {"surface", "curve", "parameter"}
        How the discrepancy pairs each edge curve with the face (`trimsurf.certify._boundary._eval_use`):
        closest point of the surface (default), of the trim curve, or the same parameter (to compare).
    point_tolerance : float or None
        Shared edges are sampled until the rigorous bound of the gap between the perturbed faces is below
        this (the model's point tolerance; default 1e-6 of the diagonal). An edge where it is not reached
        is reported and the shell is not certified.
    gap_samples : int
        Random edge parameters per shared edge at which the gap is measured (0: not measured).

    Returns
    -------
    ShellCertificate

    Raises
    ------
    InputError
        Not a Shell, no faces, or unusable trim loops (`TrimLoopError`).

    Examples
    --------
    >>> from trimsurf.samples import build_sample
    >>> cert = certify_shell(build_sample("gap_pair"))
    >>> cert.certified, [round(f.normal_bound_deg, 2) for f in cert.faces], {f.bound_kind for f in cert.faces}
    (True, [0.15, 0.3], {'rigorous'})
    >>> bool(cert.edge_gap_max <= cert.edge_gap_bound <= cert.point_tolerance)
    True
    """
    shell = _check_shell(shell)
    if not (np.isfinite(rtol) and 0 < rtol < 1):
        raise InputError(f"rtol must be in (0, 1); got {rtol!r}")
    t0 = time.perf_counter()
    diag = shell.diagonal()
    chord = diag / 100.0 if max_chord is None else float(max_chord)
    if not (np.isfinite(chord) and chord > 0):
        raise InputError(f"max_chord must be a positive number; got {max_chord!r}")
    tol = 1e-6 * diag if point_tolerance is None else float(point_tolerance)
    if not (np.isfinite(tol) and tol > 0):
        raise InputError(f"point_tolerance must be a positive number; got {point_tolerance!r}")
    if pairing not in ("surface", "curve", "parameter"):
        raise InputError(f"pairing must be 'surface', 'curve' or 'parameter'; got {pairing!r}")
    bounds, edges, _ = sample_boundaries(shell, rtol=rtol, max_chord=chord, pairing=pairing, point_tolerance=tol)
    t1 = time.perf_counter()
    faces: list[FaceCertificate] = []
    perturbed: list[PerturbedFace] = []
    for b in bounds:
        g = PerturbedFace(shell.faces[b.face], b, b.lipschitz)
        cert, g = face_certificate(g, n_domain=n_domain, max_normal_angle_deg=max_normal_angle_deg)
        faces.append(cert)
        perturbed.append(g)
        if progress:
            progress("faces", 1)
    t2 = time.perf_counter()
    pairs: list[PairCertificate] = []
    shared: dict[tuple[int, int], list[int]] = {}
    for i, e in enumerate(shell.edges):
        fs = e.faces
        for a in fs:
            for b2 in fs:
                if a < b2:
                    shared.setdefault((a, b2), []).append(i)
    if intersections:
        hier = [build_hierarchy(g, i) for i, g in enumerate(perturbed)]
        for i, h in enumerate(hier):
            found: list = []
            ok = excluded_self(h, budget=budget if faces[i].certified else min(budget, 2000), findings=found)
            if not ok:  # reported once, as the pair (i, i)
                faces[i] = dataclasses.replace(faces[i], certified=False)
            pairs_self = PairCertificate((i, i), False, [], ok, [f.as_dict() for f in found[:5]])
            if not ok:
                pairs.append(pairs_self)
            if progress:
                progress("pairs", 1)
        roots = [h.root for h in hier]
        for i in range(len(hier)):
            for j in range(i + 1, len(hier)):
                adj = (i, j) in shared
                ri, rj = roots[i], roots[j]
                if ri is None or rj is None:
                    continue
                close = not (np.any(ri.hi < rj.lo) or np.any(rj.hi < ri.lo))
                if not adj and not close:
                    continue
                found = []
                small = not (faces[i].normal_bound_deg < max_normal_angle_deg
                             and faces[j].normal_bound_deg < max_normal_angle_deg)
                ok = excluded_pair(hier[i], hier[j], budget=min(budget, 2000) if small else budget, findings=found)
                pairs.append(PairCertificate((i, j), adj, shared.get((i, j), []), ok, [f.as_dict() for f in found[:5]]))
                if progress:
                    progress("pairs", 1)
    else:
        for (i, j), es in sorted(shared.items()):
            pairs.append(PairCertificate((i, j), True, es, False, [{"reason": "intersection test not run"}]))
    t3 = time.perf_counter()
    measured = {m["edge"]: m for m in measure_edge_gaps(perturbed, edges, shell, n=gap_samples)} if gap_samples else {}
    edge_rows = []
    for k, e in enumerate(edges):
        if e.interval_bound is None:
            continue
        m = measured.get(k)
        edge_rows.append({"edge": k, "shell_edge": e.shell_edge, "faces": sorted({u.face for u in e.uses}),
                          "n_samples": int(len(e.t)), "gap_bound": float(e.gap_bound),
                          "gap_max": None if m is None else m["gap_max"], "tolerance": float(e.gap_tolerance),
                          "bound_valid": bool(np.isfinite(e.gap_bound))})
    t4 = time.perf_counter()
    settings = {"rtol": rtol, "max_chord": chord, "n_domain": n_domain, "pairing": pairing, "point_tolerance": tol,
                "gap_samples": gap_samples, "max_normal_angle_deg": max_normal_angle_deg,
                "intersections": intersections, "budget": budget}
    timings = {"boundary_sampling": t1 - t0, "faces": t2 - t1, "intersections": t3 - t2, "gap_measurement": t4 - t3,
               "total": t4 - t0}
    return ShellCertificate(shell.name, faces, pairs, perturbed, diag, settings, timings, edges, edge_rows, tol)

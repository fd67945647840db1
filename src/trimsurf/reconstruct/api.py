"""`reconstruct_mesh`: network + filling + figures, in one call."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..geom import bezier_triangle_points
from ..model import TriMesh
from ._topology import mesh_topology
from .fill import (fill_single_quintic, fill_single_septic, fill_split_quartic, fill_split_sextic)
from .peters import fill_peters_quintic
from .network import CurveNetwork, _count_inverted, _one_blas_thread, build_network
from .surface import PatchSet, g1_continuity

__all__ = ["FILLS", "Reconstruction", "reconstruct_mesh", "vertex_interpolation_error", "sphere_fit",
           "inverted_corners", "chain_kinks_deg",
           "radial_deviation"]

FILLS = ("split", "single", "peters")


@dataclass(frozen=True, eq=False)
class Reconstruction:
    """Result of `reconstruct_mesh`.

    Attributes
    ----------
    patches : PatchSet
    network : CurveNetwork
    report : dict
        ``vertices``, ``patches``, ``iterations``, ``g0_gap``, ``g1_angle_max_deg``,
        ``vertex_interpolation_error``, ``seconds`` and more (see `reconstruct_mesh`).
    """

    patches: PatchSet
    network: CurveNetwork
    report: dict = field(default_factory=dict)

    def __bool__(self) -> bool:
        return self.patches.n_patches > 0


def vertex_interpolation_error(ps: PatchSet) -> float:
    """Largest distance between a mesh vertex and the patch corners that should interpolate it.

    Every patch is evaluated (de Casteljau) at its three corners; single patches must hit
    the facet's corners 0, 1, 2, split patch k the facet's corners k and k + 1.
    """
    T, V = ps.mesh_triangles, ps.mesh_vertices
    corners = bezier_triangle_points(ps.control_points, ps.degree, np.eye(3))     # (P, 3, 3)
    single = ps.sub < 0
    k = np.where(single, 0, ps.sub)
    err = 0.0
    for c in range(3):
        target = V[T[ps.facet, (k + c) % 3]]
        use = single if c == 2 else np.ones(len(k), bool)
        if use.any():
            err = max(err, float(np.abs(corners[use, c] - target[use]).max()))
    return err


def inverted_corners(net: CurveNetwork) -> int:
    """Facet corners whose two network tangents turn the wrong way about the vertex normal.

    At such a corner the facet's wedge is folded over in the tangent plane, and any
    filling folds there (the G1 angle across a nearby curve becomes 180 degrees). Happens
    on noisy meshes where no single tangent plane sees all facets of a vertex in order.
    """
    return _count_inverted(net.topology, net.curves, net.normals)


def chain_kinks_deg(net: CurveNetwork, chains) -> float:
    """Largest kink (degrees) between consecutive network curves along the given vertex chains.

    0 when every chain is one G1 curve (what `feature_chains` enforces). A closed chain
    (first = last vertex, more than 3 entries) is also checked at its first vertex. The
    angle is atan2(|a x b|, -a.b), accurate to rounding near 0 (arccos of the cosine
    would be off by ~1e-8 rad there).
    """
    from .network import _edge_lookup

    topo = net.topology
    n, E, c = topo.n_vertices, topo.edges, net.curves
    d = net.degree
    worst = 0.0
    for chain in chains:
        ch = np.asarray(chain, dtype=np.int64)
        if len(ch) < 3:
            continue
        if len(ch) > 3 and ch[0] == ch[-1]:
            ch = np.r_[ch, ch[1]]
        a, m, b = ch[:-2], ch[1:-1], ch[2:]
        out = []
        for other in (a, b):
            eid, fwd = _edge_lookup(E, n, m, other)
            t = np.where(fwd[:, None], d * (c[eid, 1] - c[eid, 0]), d * (c[eid, -2] - c[eid, -1]))
            out.append(t)
        ang = np.arctan2(np.linalg.norm(np.cross(out[0], out[1]), axis=1),
                         -np.einsum("ij,ij->i", out[0], out[1]))
        worst = max(worst, float(np.degrees(ang).max()))
    return worst


def sphere_fit(points) -> tuple[np.ndarray, float, float]:
    """Least-squares sphere (centre, radius) through points and the largest radial residual."""
    P = np.asarray(points, dtype=np.float64)
    A = np.c_[2 * P, np.ones(len(P))]
    sol = np.linalg.lstsq(A, np.einsum("ij,ij->i", P, P), rcond=None)[0]
    c = sol[:3]
    r = float(np.sqrt(max(sol[3] + c @ c, 0.0)))
    res = float(np.abs(np.linalg.norm(P - c, axis=1) - r).max()) if len(P) else 0.0
    return c, r, res


def radial_deviation(ps: PatchSet, center, radius, *, density: int = 12) -> tuple[float, float]:
    """Max and RMS of | |x - c| - r | over the surface sampled at `density`."""
    m = ps.evaluate_mesh(density, weld=False)
    d = np.linalg.norm(m.vertices - np.asarray(center), axis=1) - radius
    return float(np.abs(d).max()), float(np.sqrt(np.mean(d * d)))


def reconstruct_mesh(mesh: TriMesh, *, network: str = "g1", fill: str = "split", direction: str = "d2",
                     length: str = "l2", functional: str = "arc-length", weighting: str = "angle",
                     max_iterations: int = 20, tol_deg: float = 1e-3, feature_chains=(),
                     modified_inner: bool | None = None, n_samples: int = 17, progress=None,
                     second: str = "zero") -> Reconstruction:
    """Smooth triangular Bézier surface through the vertices of a triangle mesh (MNN paper).

    Parameters
    ----------
    mesh : TriMesh
        Consistently oriented 2-manifold (closed or with boundary), no degenerate triangles.
    network : {"g1", "g2", "shirman-sequin"}
        Optimized cubic G1 network, optimized quintic G2 network, or the Shirman-Séquin
        baseline network.
    fill : {"split", "single", "peters"}
        Cubic networks: "split" = Shirman-Séquin split (3 quartics per facet, exactly G1);
        "peters" = Peters' scheme, one quintic per facet meeting its neighbours by scalar
        weight functions, solved as one sparse least-squares system (`fill_peters_quintic`:
        G1 where the vertex enclosure problem is solvable, "some error in the G1 match"
        elsewhere, as the paper says); "single" = one quintic per facet from a
        Chiyokura-Kimura cross-boundary field with averaged corner twists (not G1 in
        general; `fill_single_quintic`). G2 network: "split" = modified split of degree 6,
        "single" = one degree-7 patch per facet with the split as fallback where it would be
        singular (both G1). Every fill is measured, not assumed: see the report keys.
    direction, length, functional, weighting, max_iterations, tol_deg, feature_chains
        See `build_network`.
    second : {"zero", "l3", "l4"}
        G2 network: second-derivative curve parameter s (paper section 5): 0, from the
        de Boor-Höllig-Sabin cubic ("l3"), or that with its direction optimized too ("l4");
        "l3"/"l4" use the L3 tangent lengths (the report's ``length`` says "l3"). See
        `trimsurf.reconstruct.network`.
    modified_inner : bool, optional
        The paper's modified first inner control point of the quartic split (default: on for
        the MNN networks, off for the Shirman-Séquin baseline).
    n_samples : int
        Samples per patch edge (ends excluded) for the G0/G1 and curvature-jump figures;
        they are maxima over these samples (``g1_sampling`` in the report says so).
    progress : callable, optional
        Called with a short stage name ("network", "fill", "check").

    Returns
    -------
    Reconstruction
        report keys: vertices, triangles, patches, degree, iterations, converged, g0_gap,
        g1_error_max_deg (largest normal-angle jump across any patch edge: network curves and
        the inner curves of split facets), g1_angle_max_deg (across the network curves),
        g1_angle_rms_deg, g1_angle_inner_max_deg, g1_sampling (how the G1 figures were
        sampled), curvature_jump_max (largest jump of the normal curvature perpendicular to
        a patch edge, 1/length, sampled), mean_curvature_jump_max, curvature_on_edges_max
        (largest |normal curvature| there, for scale), g1_condition_residual_max and
        g1_residual_vertices (Peters' fill: residual of its G1 equations and the vertices
        where it stays), vep_even_vertices (Peters' fill: inner vertices of even valence, where
        the vertex enclosure constraint applies), weight_sign_changes (Peters' fill: curves
        whose weights are not positive at an end), vertex_interpolation_error,
        seconds, network_seconds, fill_seconds, single_patch_fallbacks, inverted_corners (facet
        corners folded in the tangent plane), folded_edges (curves where the patches meet at
        more than 90 degrees, i.e. fold back), and the options.

    Raises
    ------
    InputError
        Bad options; non-manifold, degenerate, badly oriented meshes or isolated vertices.

    Examples
    --------
    >>> from trimsurf.samples import octahedron
    >>> rec = reconstruct_mesh(octahedron())
    >>> rec.report["patches"], rec.report["vertex_interpolation_error"] < 1e-12
    (24, True)
    """
    if fill not in FILLS:
        raise InputError(f"fill must be one of {', '.join(FILLS)}; got {fill!r}")
    if second != "zero" and network != "g2":
        raise InputError(f"second={second!r} sets the G2 network's second derivatives; use network='g2'")
    if network == "g2" and fill == "peters":
        raise InputError("fill 'peters' fills cubic networks; use --fill single or split with the g2 network")
    with _one_blas_thread():
        return _reconstruct(mesh, network, fill, direction, length, functional, weighting, max_iterations, tol_deg,
                            feature_chains, modified_inner, n_samples, progress, second)


def _reconstruct(mesh, network, fill, direction, length, functional, weighting, max_iterations, tol_deg,
                 feature_chains, modified_inner, n_samples, progress, second="zero") -> Reconstruction:
    t0 = time.perf_counter()
    say = progress or (lambda stage: None)
    topo = mesh_topology(mesh)
    say("network")
    net = build_network(topo, kind=network, direction=direction, length=length, functional=functional,
                        weighting=weighting, max_iterations=max_iterations, tol_deg=tol_deg,
                        feature_chains=feature_chains, second=second)
    t1 = time.perf_counter()
    say("fill")
    n_fb = 0
    peters_info: dict = {}
    if net.degree == 3:
        if fill == "split":
            mod = (network != "shirman-sequin") if modified_inner is None else bool(modified_inner)
            fp = fill_split_quartic(net, modified=mod)
        elif fill == "peters":
            fp, peters_info = fill_peters_quintic(net)
        else:
            fp = fill_single_quintic(net)
    else:
        if fill == "split":
            fp = fill_split_sextic(net)
        else:
            fp, n_fb = fill_single_septic(net)
    t2 = time.perf_counter()
    if second != "zero":
        length = "l3"
    options = {"network": network, "fill": fill, "direction": direction, "length": length, "second": second,
               "functional": functional, "weighting": weighting}
    ps = PatchSet.from_patches(fp, topo.vertices, topo.triangles, meta=options)
    say("check")
    cont = g1_continuity(ps, n_samples=n_samples, curvature=True)
    report = {"vertices": topo.n_vertices, "triangles": int(len(topo.triangles)), "patches": ps.n_patches,
              "degree": ps.degree, "iterations": net.iterations, "converged": net.converged,
              "g0_gap": cont["g0_gap"],
              "g1_error_max_deg": max(cont["g1_angle_max_deg"], cont["g1_angle_inner_max_deg"]),
              "g1_angle_max_deg": cont["g1_angle_max_deg"],
              "g1_angle_rms_deg": cont["g1_angle_rms_deg"],
              "g1_angle_inner_max_deg": cont["g1_angle_inner_max_deg"],
              "g1_sampling": f"sampled: {n_samples} points inside every patch edge (maxima over the samples, "
                             f"not bounds)",
              "curvature_jump_max": cont["curvature_jump_max"],
              "mean_curvature_jump_max": cont["mean_curvature_jump_max"],
              "curvature_on_edges_max": cont["curvature_on_edges_max"],
              "g1_condition_residual_max": peters_info.get("g1_condition_residual_max", 0.0),
              "g1_residual_vertices": peters_info.get("g1_residual_vertices", 0),
              "vep_even_vertices": int(peters_info.get("vep_even_vertices", 0)),
              "weight_sign_changes": int(peters_info.get("weight_sign_changes", 0)),
              "vertex_interpolation_error": vertex_interpolation_error(ps),
              "single_patch_fallbacks": n_fb, "inverted_corners": inverted_corners(net),
              "folded_edges": int((cont["edge_angles_deg"] > 90.0).sum()),
              "network_seconds": t1 - t0, "fill_seconds": t2 - t1,
              "feature_chains": len(feature_chains),
              "feature_kink_max_deg": chain_kinks_deg(net, feature_chains) if feature_chains else 0.0,
              **options}
    report["seconds"] = time.perf_counter() - t0
    return Reconstruction(ps, net, report)

"""The report's measurement shortcuts of session 29 (issue 17, item 2), each against the path it replaces.

Warm-started first pass (`deviation._first_pass`, `_project_warm`): a face's vertices are projected with
the full search, every other first-pass sample (edge nodes, centroids) with one Newton run from the same
barycentric combination of its corners' feet, searched in full where that run does not converge, ends on
a domain edge or beyond its triangle's bound (longest edge + smallest corner distance). Checks:

- every first-pass sample's distance equals the full search's within 1e-9 relative plus the projection
  tolerance, on every face of featuretype and t20 at the defaults (the same foot), and the warm runs did
  the work (few rows searched in full);
- broken on purpose, it fails: starts mirrored in the domain (a wrong foot) without the guards end at
  other local minima; with the guards (the foot within its footprint's reach of the start, the distance
  within the corners' bound) every one is searched in full;
- the corners' distance bound is needed: on linkrods and abc (tolerance only) runs from the right start
  end at other local minima, and without the bound the report's maximum is 250-280x the full search's;
- the report's figures with and without the warm first pass agree within 1e-9 relative.
"""

import numpy as np
import pytest

import trimsurf.quality.deviation as D
from trimsurf.io import read_shell
from trimsurf.quality.sampling import as_face, sample_triangles
from trimsurf.tessellate import tessellate_shell
from trimsurf.tessellate.measure import measure_mesh

FIGURES = ("max_deviation", "max_deviation_mesh_to_faces", "max_deviation_faces_to_mesh", "max_deviation_bound")


def _tessellate(shared_data, name, edge):
    shell = read_shell(shared_data / "cad" / name)
    d = shell.diagonal()
    return shell, tessellate_shell(shell, tolerance=1e-3 * d, max_edge=edge * d, measure=False)


def _mismatches(mesh, shell):
    """First-pass samples of every face whose `_first_pass` distance differs from the full search's by more
    than 1e-9 relative + the projection tolerance, and the samples compared."""
    order = np.argsort(mesh.face_id, kind="stable")
    bounds = np.searchsorted(mesh.face_id[order], np.arange(len(shell.faces) + 1))
    bad = n = 0
    for i in range(len(shell.faces)):
        if bounds[i + 1] == bounds[i]:
            continue
        sub = mesh.submesh(np.sort(order[bounds[i]:bounds[i + 1]]))
        face = as_face(shell.faces[i])
        s = sample_triangles(sub, density=3)
        warm, _, _ = D._first_pass(sub, face, s, np.arange(len(s.points)), 1e-10)
        full = D.project_to_face(s.points, face, tol_rel=1e-10)
        cp = np.asarray(face.surface.control_points).reshape(-1, 3)
        tol = 1e-10 * float(np.linalg.norm(cp.max(axis=0) - cp.min(axis=0)))
        bad += int(np.count_nonzero(~(np.abs(warm - full.distance) <= 1e-9 * full.distance + tol)))
        n += len(warm)
    return bad, n


@pytest.mark.parametrize("name", ["trimesh__featuretype.STEP", "gmsh__t20_data.step"])
def test_warm_first_pass_same_feet(shared_data, monkeypatch, name):
    shell, res = _tessellate(shared_data, name, 3e-2)
    rows = {"warm": 0, "full": 0}
    proj = D.project_to_face

    def counting(points, face, **k):
        rows["warm" if k.get("uv0") is not None else "full"] += len(points)
        return proj(points, face, **k)
    with monkeypatch.context() as m:
        m.setattr(D, "project_to_face", counting)
        bad, n = _mismatches(res.mesh, shell)
    assert n > 50000
    assert bad == 0
    # the vertices (~1/8 of the samples) and the fallbacks in full, the rest warm (the comparison's own full
    # search is `rows["full"]`'s other n)
    assert rows["warm"] > 0.75 * n and rows["full"] - n < 0.25 * n


def test_warm_from_wrong_foot_fails(shared_data, monkeypatch):
    shell, res = _tessellate(shared_data, "trimesh__featuretype.STEP", 3e-2)
    warm = D._project_warm

    def mirrored(points, face, uv0, bound, tol_rel, reach=None, guard=True):
        (u0, u1), (v0, v1) = face.surface.domain
        uv = np.column_stack([u0 + u1 - uv0[:, 0], v0 + v1 - uv0[:, 1]])
        return warm(points, face, uv, bound if guard else np.full(len(bound), np.inf), tol_rel,
                    reach if guard else None)
    with monkeypatch.context() as m:
        m.setattr(D, "_project_warm", lambda *a: mirrored(*a, guard=False))
        unguarded, n = _mismatches(res.mesh, shell)
        m.setattr(D, "_project_warm", mirrored)
        guarded, _ = _mismatches(res.mesh, shell)
    assert unguarded > 100                  # other local minima: the comparison sees them
    assert guarded == 0                     # the feet left their footprints: all searched in full


@pytest.mark.parametrize("name", ["occt__linkrods.step", "occtpr946__bug32596_abc_0_13.step"])
def test_warm_distance_bound_needed(shared_data, monkeypatch, name):
    """Faces that fold back (linkrods) or wrap (abc): warm runs from the right corners' feet that end at
    another local minimum, inside their footprint's reach but beyond their corners' bound. With the
    bound, the figures are the full search's within 1e-9; without it they are 250-280x as large."""
    shell, res = _tessellate(shared_data, name, 1.0)
    new = measure_mesh(res.mesh, shell)
    with monkeypatch.context() as m:
        m.setattr(D, "WARM_FIRST_PASS", False)
        old = measure_mesh(res.mesh, shell)
    assert abs(new["max_deviation"] - old["max_deviation"]) <= 1e-9 * old["max_deviation"]
    warm = D._project_warm
    with monkeypatch.context() as m:
        m.setattr(D, "_project_warm", lambda p, f, u, b, t, r=None: warm(p, f, u, np.full(len(b), np.inf), t, r))
        broken = measure_mesh(res.mesh, shell)
    assert broken["max_deviation"] > 10 * old["max_deviation"]


@pytest.mark.parametrize("name, edge", [("occt__screw.step", 1.0), ("trimesh__featuretype.STEP", 3e-2)])
def test_warm_first_pass_figures(shared_data, monkeypatch, name, edge):
    shell, res = _tessellate(shared_data, name, edge)
    new = measure_mesh(res.mesh, shell)
    with monkeypatch.context() as m:
        m.setattr(D, "WARM_FIRST_PASS", False)
        old = measure_mesh(res.mesh, shell)
    for k in FIGURES:
        assert abs(new[k] - old[k]) <= 1e-9 * old[k], (k, new[k], old[k])
    assert new["flipped"] == old["flipped"] and new["deviation_samples"] == old["deviation_samples"]

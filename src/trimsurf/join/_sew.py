"""Inputs for the paper's real case: faces meshed independently, and unsewn models sewn first.

* `mesh_faces_independently`: every face meshed ALONE by Open CASCADE, at its own deflection (a
  different fraction of the requested one for every face), so that two faces along a shared edge put
  their boundary nodes at different places -- the meshes of Sec. I (Fig. 2) whose boundaries do not
  match, unlike `io.occ_mesh_faces`, where Open CASCADE meshes each shared edge once for both faces.
* `sew_shell`: a shell whose faces share no edge (an IGES surface model such as ``occt__bearing.iges``)
  sewn by Open CASCADE's ``BRepBuilderAPI_Sewing`` and read back, so the join knows which faces adjoin.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..model import Shell, TriMesh

__all__ = ["mesh_faces_independently", "independent_deflections", "sew_shell", "needs_sewing"]

_GOLDEN = 0.6180339887498949


def independent_deflections(n_faces: int, deflection: float) -> np.ndarray:
    """Per-face deflections in [0.5, 1] x `deflection`, all different (face i: 0.5 + 0.5 frac(i phi)).

    Examples
    --------
    >>> d = independent_deflections(4, 1.0)
    >>> bool(np.all((d >= 0.5) & (d <= 1.0))) and len(set(d.round(9))) == 4
    True
    """
    i = np.arange(n_faces)
    return deflection * (0.5 + 0.5 * ((i * _GOLDEN) % 1.0))


def mesh_faces_independently(shell: Shell, deflection: float, *, angular_deflection: float = 0.5) -> list[TriMesh]:
    """Mesh every face of `shell` on its own (Open CASCADE, one shape per face) at `independent_deflections`.

    The per-face meshes do not share their boundary nodes with the neighbours (each face discretizes its
    edges itself, at its own deflection). Returns one `TriMesh` per face (uv from Open CASCADE).
    """
    from ..io import occ_mesh_faces

    if not (np.isfinite(deflection) and deflection > 0):
        raise InputError(f"deflection must be a positive number; got {deflection!r}")
    out = []
    for face, d in zip(shell.faces, independent_deflections(len(shell.faces), deflection)):
        out.append(occ_mesh_faces(Shell((face,), (), np.zeros((0, 3)), name=face.name), linear_deflection=float(d),
                                  angular_deflection=angular_deflection)[0])
    return out


def needs_sewing(shell: Shell) -> bool:
    """Several faces and not one edge shared by two of them (an unsewn surface model)."""
    return len(shell.faces) > 1 and not any(len({u[0] for u in e.uses}) >= 2 for e in shell.edges)


def sew_shell(shell: Shell, tolerance: float | None = None) -> Shell:
    """The shell sewn by Open CASCADE (``BRepBuilderAPI_Sewing``, default tolerance 1e-4 of the diagonal).

    Faces come back in Open CASCADE's order (mesh the returned shell, not the input one).
    """
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Sewing

    from ..io._occ._read import nurbs_shape, quiet_occ
    from ..io._occ._to_shape import shell_to_shape
    from ..io._occ._to_shell import shape_to_shell

    tol = 1e-4 * shell.diagonal() if tolerance is None else float(tolerance)
    if not (np.isfinite(tol) and tol > 0):
        raise InputError(f"sewing tolerance must be a positive number; got {tolerance!r}")
    with quiet_occ():
        shape = shell_to_shape(shell)
        sewing = BRepBuilderAPI_Sewing(tol)
        sewing.Add(shape)
        sewing.Perform()
        sewn = sewing.SewedShape()
        if sewn.IsNull():
            return shell
        out = shape_to_shell(nurbs_shape(sewn), name=shell.name)
    if len(out.faces) != len(shell.faces):
        raise InputError(f"{shell.name or 'shell'}: sewing changed the number of faces "
                         f"({len(shell.faces)} -> {len(out.faces)})")
    return out

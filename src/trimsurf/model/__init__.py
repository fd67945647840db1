"""Frozen dataclasses that hold arrays: curves, surfaces, trimmed faces, shells, meshes."""

from .bezier_triangle import BezierTriangle, BezierTriangleSurface
from .mesh import TriMesh
from .nurbs import NurbsCurve, NurbsSurface
from .shell import Edge, Shell
from .trim import Loop, PCurve, TrimmedFace

__all__ = ["NurbsCurve", "NurbsSurface", "PCurve", "Loop", "TrimmedFace", "Edge", "Shell", "TriMesh",
           "BezierTriangle", "BezierTriangleSurface"]

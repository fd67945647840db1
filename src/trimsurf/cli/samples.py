"""``trimsurf samples``: list the embedded sample models or write one to a file."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..errors import InputError
from ._common import EXIT_OK, examples, format_table, print_json

__all__ = ["NAME", "HELP", "add_args", "run", "write_sample"]

NAME = "samples"
HELP = "list the embedded sample models or write one to a file"
DESCRIPTION = """\
List the embedded sample models (built procedurally, no download) or write one.
CAD samples (trimmed B-spline faces) are written as STEP (.step/.stp), Open
CASCADE BREP (.brep) or VDAFS (.vda); mesh samples as OBJ, PLY, STL, OFF, glTF,
GLB, VTK/VTU, Gmsh MSH, Abaqus INP or Nastran BDF, chosen by the suffix."""
EPILOG = examples("trimsurf samples --list",
                  "trimsurf samples fender --out fender.step",
                  "trimsurf samples s_cone --out s_cone.obj")


def add_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("name", nargs="?", help="sample to write (see --list)")
    parser.add_argument("--list", action="store_true", help="list the samples (the default without NAME)")
    parser.add_argument("--out", type=Path, metavar="FILE", help="file to write; the format comes from the suffix")
    parser.add_argument("--json", action="store_true", help="with --list: print the list as JSON")


def write_sample(name: str, path: Path) -> list[Path]:
    """Build sample `name` and write it to `path` (format by suffix); returns the written paths.

    Raises
    ------
    InputError
        Unknown sample, or a suffix that does not fit the sample's kind.
    """
    from .. import io
    from ..samples import SAMPLES, build_sample

    if name not in SAMPLES:
        raise InputError(f"unknown sample {name!r}; choose one of {', '.join(SAMPLES)}")
    sample = SAMPLES[name]
    suffix = path.suffix.lower()
    if sample.kind == "shell":
        allowed = tuple(s for s in io.CAD_SUFFIXES if not s.startswith((".ig",)))
        if suffix not in allowed:
            raise InputError(f"{path}: sample {name!r} is a CAD shell; write it as one of {', '.join(allowed)}")
        io.write_shell(build_sample(name), path)
    else:
        if suffix not in io.MESH_SUFFIXES:
            raise InputError(f"{path}: sample {name!r} is a mesh; write it as one of {', '.join(io.MESH_SUFFIXES)}")
        io.write_mesh(build_sample(name), path)
    return [path]


def run(args: argparse.Namespace) -> int:
    from ..samples import SAMPLES

    if args.name is None or args.list:
        if args.name is not None or args.out is not None:
            raise InputError("--list takes no NAME or --out")
        if args.json:
            print_json([{"name": s.name, "kind": s.kind, "description": s.description} for s in SAMPLES.values()])
        else:
            print(format_table([[s.name, s.kind, s.description] for s in SAMPLES.values()]))
        return EXIT_OK
    if args.out is None:
        raise InputError(f"say where to write sample {args.name!r} with --out FILE")
    if args.json:
        raise InputError("--json goes with --list")
    for p in write_sample(args.name, args.out):
        print(f"wrote {p}", file=sys.stderr)
    return EXIT_OK

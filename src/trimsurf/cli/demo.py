"""``trimsurf demo``: run every capability on the embedded samples; write outputs, summary.json, report.html."""

from __future__ import annotations

import argparse
import base64
import datetime as _dt
import html
import sys
import time
import warnings
from pathlib import Path

from .. import __version__
from ..errors import InputError, TrimsurfWarning
from ._common import EXIT_FAILED, EXIT_OK, examples, one_line, print_error, print_warning, progress, write_json
from .demo_steps import STEPS, StepContext

__all__ = ["NAME", "HELP", "add_args", "run", "run_demo", "write_report"]

NAME = "demo"
HELP = "run every capability on the embedded samples and write the outputs and a report"
DESCRIPTION = """\
Build every embedded sample, run every capability that exists on it, and write
into DIR: the samples' files, `trimsurf info`-style reports, summary.json (per
sample: which steps ran, their figures, timings and failures) and report.html
(self-contained, a section per sample). Exit status 0 when every step passed,
1 when a step failed (summary.json and stderr name it)."""
EPILOG = examples("trimsurf demo",
                  "trimsurf demo --out demo-out --quick",
                  "trimsurf demo --sample fender --sample s_cone --out /tmp/demo")


def add_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", type=Path, default=Path("trimsurf-demo"), metavar="DIR",
                        help="output folder (created; default ./trimsurf-demo)")
    parser.add_argument("--quick", action="store_true", help="skip the slow steps (read-back checks)")
    parser.add_argument("--sample", action="append", metavar="NAME",
                        help="run only this sample (repeatable; default all)")


def run(args: argparse.Namespace) -> int:
    summary = run_demo(args.out, quick=args.quick, names=args.sample)
    for name, sec in summary["samples"].items():
        for sname, st in sec["steps"].items():
            if st["status"] == "failed":
                print_error(f"demo step {sname!r} failed on sample {name!r}: {st['error']}")
    n_failed = len(summary["failed"])
    print(f"demo: {len(summary['samples'])} samples, {summary['n_steps']} steps, {n_failed} failed, "
          f"{summary['seconds']:.1f} s; see {args.out / 'report.html'}", file=sys.stderr)
    return EXIT_FAILED if n_failed else EXIT_OK


def _run_step(fn, ctx: StepContext) -> dict:
    """Run one step; catch its exception and warnings; return its summary entry."""
    t0 = time.perf_counter()
    entry: dict = {"status": "ok", "seconds": 0.0, "figures": {}, "files": [], "images": [], "warnings": [],
                   "error": None}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", TrimsurfWarning)
        try:
            out = fn(ctx)
        except KeyboardInterrupt:
            raise
        except Exception as exc:  # a failed step is reported, the demo goes on
            entry["status"] = "failed"
            entry["error"] = f"{type(exc).__name__}: {one_line(exc)}"
            out = None
    entry["seconds"] = time.perf_counter() - t0
    for w in caught:
        if issubclass(w.category, TrimsurfWarning):
            entry["warnings"].append(one_line(w.message))
            print_warning(f"{ctx.sample}: {w.message}")
        else:  # not ours: hand it back to the filters in force
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    if out is not None:
        entry["figures"] = out.figures
        ctx.images.extend(out.images)
        entry["files"] = [_rel(p, ctx.out_dir) for p in out.files]
        entry["images"] = [_rel(p, ctx.out_dir) for p in out.images]
    return entry


def _rel(path: Path, base: Path) -> str:
    try:
        return str(Path(path).resolve().relative_to(base.resolve()))
    except ValueError:
        return str(path)


def run_demo(out_dir: Path, *, quick: bool = False, names: list[str] | None = None) -> dict:
    """Run the demo into `out_dir`; returns the summary (also written as summary.json and report.html).

    Parameters
    ----------
    out_dir : Path
        Created if missing.
    quick : bool
        Skip steps registered as slow.
    names : list of str or None
        Samples to run (default all).

    Raises
    ------
    InputError
        An unknown sample name, or an `out_dir` that is a file.
    """
    from ..samples import SAMPLES

    names = list(SAMPLES) if not names else names
    unknown = [n for n in names if n not in SAMPLES]
    if unknown:
        raise InputError(f"unknown sample {unknown[0]!r}; choose from {', '.join(SAMPLES)}")
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise InputError(f"{out_dir}: exists and is not a folder")
    out_dir.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()
    summary: dict = {"trimsurf_version": __version__,
                     "started": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
                     "quick": quick, "steps_registered": [s.name for s in STEPS], "samples": {}, "failed": [],
                     "n_steps": 0}
    plan = {n: [s for s in STEPS if SAMPLES[n].kind in s.kinds and not (quick and s.slow)] for n in names}
    with progress(sum(len(p) + 1 for p in plan.values()), "demo") as bar:
        for name in names:
            sample = SAMPLES[name]
            section: dict = {"description": sample.description, "kind": sample.kind, "steps": {}, "images": []}
            summary["samples"][name] = section
            holder: dict = {}

            def build(_ctx, _sample=sample, _holder=holder):
                _holder["obj"] = _sample.build()
                from .demo_steps import StepOutput
                return StepOutput()

            bar.advance(0, description=f"{name}: build")
            ctx = StepContext(name, sample.kind, None, out_dir, quick)  # type: ignore[arg-type]
            section["steps"]["build"] = _run_step(build, ctx)
            bar.advance()
            summary["n_steps"] += 1
            if "obj" not in holder:
                summary["failed"].append(f"{name}/build")
                continue
            ctx.obj = holder["obj"]
            for st in plan[name]:
                bar.advance(0, description=f"{name}: {st.name}")
                entry = _run_step(st.run, ctx)
                section["steps"][st.name] = entry
                summary["n_steps"] += 1
                if entry["status"] == "failed":
                    summary["failed"].append(f"{name}/{st.name}")
                bar.advance()
            section["images"] = [_rel(p, out_dir) for p in ctx.images]
    summary["seconds"] = time.perf_counter() - t_start
    write_json(summary, out_dir / "summary.json")
    write_report(summary, out_dir / "report.html", out_dir)
    return summary


_CSS = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 60em; color: #222; }
h1 { font-size: 1.6em; } h2 { font-size: 1.25em; border-bottom: 1px solid #ccc; margin-top: 2em; }
table { border-collapse: collapse; margin: 0.5em 0; font-size: 0.9em; }
th, td { border: 1px solid #ddd; padding: 0.25em 0.6em; text-align: left; vertical-align: top; }
th { background: #f4f4f4; } .ok { color: #176317; } .failed { color: #b00020; font-weight: bold; }
code { font-size: 0.9em; } img { max-width: 100%; border: 1px solid #ddd; margin: 0.3em 0; }
.figures td:first-child { color: #555; }
"""


def _fmt(value) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    if isinstance(value, dict):
        return ", ".join(f"{k}: {_fmt(v)}" for k, v in value.items())
    if isinstance(value, (list, tuple)):
        return ", ".join(_fmt(v) for v in value)
    return str(value)


def _img_tag(path: Path) -> str:
    """An <img> with the PNG embedded as a data URI (the report stays one self-contained file)."""
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    return f'<img alt="{html.escape(path.name)}" src="data:image/png;base64,{data}">'


def write_report(summary: dict, path: Path, out_dir: Path) -> None:
    """Write the self-contained HTML report of a demo summary.

    Each sample gets a section: its description, a table of steps (status,
    seconds, figures, files) and the PNG pictures listed in the section's
    ``images`` (paths relative to `out_dir`), embedded as data URIs.
    """
    from ..io._atomic import atomic_path

    esc = html.escape
    parts = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
             "<title>trimsurf demo</title>", f"<style>{_CSS}</style></head><body>",
             "<h1>trimsurf demo</h1>",
             f"<p>trimsurf {esc(str(summary['trimsurf_version']))}, started {esc(summary['started'])}, "
             f"{summary['seconds']:.1f} s, {summary['n_steps']} steps, "
             + (f'<span class="failed">{len(summary["failed"])} failed: {esc(", ".join(summary["failed"]))}</span>'
                if summary["failed"] else '<span class="ok">all passed</span>') + ".</p>",
             "<ul>" + "".join(f'<li><a href="#{esc(n)}">{esc(n)}</a>: {esc(s["description"])}</li>'
                              for n, s in summary["samples"].items()) + "</ul>"]
    for name, sec in summary["samples"].items():
        parts.append(f'<h2 id="{esc(name)}">{esc(name)} <small>({esc(sec["kind"])})</small></h2>')
        parts.append(f"<p>{esc(sec['description'])}</p>")
        parts.append("<table><tr><th>step</th><th>status</th><th>seconds</th><th>figures</th><th>files</th></tr>")
        for sname, st in sec["steps"].items():
            figs = "".join(f"<tr><td>{esc(str(k))}</td><td>{esc(_fmt(v))}</td></tr>" for k, v in st["figures"].items())
            if st["error"]:
                figs += f'<tr><td>error</td><td class="failed">{esc(st["error"])}</td></tr>'
            for w in st["warnings"]:
                figs += f"<tr><td>warning</td><td>{esc(w)}</td></tr>"
            files = "<br>".join(f'<a href="{esc(f)}"><code>{esc(f)}</code></a>' for f in st["files"])
            parts.append(f'<tr><td>{esc(sname)}</td><td class="{esc(st["status"])}">{esc(st["status"])}</td>'
                         f'<td>{st["seconds"]:.3f}</td><td><table class="figures">{figs}</table></td>'
                         f"<td>{files}</td></tr>")
        parts.append("</table>")
        for rel in sec["images"]:
            p = out_dir / rel
            if p.suffix.lower() == ".png" and p.is_file():
                parts.append(_img_tag(p))
    parts.append("</body></html>")
    with atomic_path(path) as tmp:
        tmp.write_text("\n".join(parts) + "\n", encoding="utf-8")

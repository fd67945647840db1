"""Split the session log benchmarks/RESULTS.md into RESULTS.md (latest run per script) and HISTORY.md, and check it.

Not a benchmark: the tool that keeps RESULTS.md "the latest table of each benchmark". Until session 29 every
branch appended a ``## `` section to RESULTS.md; this script takes such a log (any git revision or file) and
writes

* RESULTS.md: an intro, a table of contents, then one section per script of ``benchmarks/*.py`` grouped by
  capability (``SPEC`` below: what the script measures, the command, and the LATEST run's section or
  ``### `` sub-section of the log copied verbatim, its headings demoted under the script's heading);
* HISTORY.md: every other section and sub-section of the log, verbatim and in the log's order (a one-line
  pointer where a block moved to RESULTS.md).

and checks that nothing was lost: every non-empty line of the log appears in RESULTS.md + HISTORY.md at least
as often (heading lines compared without their ``#`` level, the only change made to a copied line), and
HISTORY.md's lines from the log come in the log's order.

    python benchmarks/check_results_split.py split [--log REV_OR_FILE]   # default: the log as of ab5c52f
    python benchmarks/check_results_split.py check [--log REV_OR_FILE]

``check`` verifies the split as ``split`` made it (commit ec2c723, session 29). RESULTS.md and HISTORY.md are
edited by hand after that (a rerun's block put above its script's older one, whose heading then says
"Previous run", which the check reads as the log's "Latest run"): ``git show ec2c723:benchmarks/RESULTS.md``
is the state ``split`` made.

A section of the log that ``SPEC`` does not name goes to HISTORY.md and ``split`` lists it ("history: ..."):
if it is the newest run of a script, add it to that script's ``latest`` in ``SPEC`` (the older block then goes
to HISTORY.md) and rerun ``split``. ``split`` fails when a selector of ``SPEC`` matches no block of the log.

Rebasing this split on a main whose RESULTS.md is still the log with new sections appended: take main's
RESULTS.md (``git checkout --ours benchmarks/RESULTS.md`` during a rebase conflict, or just
``--log main``), run ``split --log main``, assign the new sections in ``SPEC``, set ``DEFAULT_LOG`` to that
revision, rerun ``split`` and ``check``. Merging a branch that still appended to the log form AFTER this split
is on main: ``split --log DEFAULT_LOG --add-from BRANCH`` (the branch's new sections appended to the log), assign
them in ``SPEC``, rerun; ``check`` with the same arguments.
"""
from __future__ import annotations

import argparse
import collections
import re
import subprocess
import sys
import textwrap
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BENCH = ROOT / "benchmarks"
DEFAULT_LOG = "ab5c52f"  # main when the log was split (session 29); later logs: pass the revision


@dataclass
class Script:
    name: str
    what: str
    command: str
    latest: list = field(default_factory=list)  # selectors: (section heading prefix, sub-heading prefix | None)
    notes: list = field(default_factory=list)   # extra lines (pointers to runs quoted in other sections)


# ---------------------------------------------------------------------------------------------------------
# Which block of the log is each script's latest run. A selector (S, None) is the whole "## S..." section;
# (S, T) its "### T..." sub-section; (S, "") the section's lines before its first "### "; a list of selectors:
# alternatives, newest first (the first the log holds is taken, so SPEC serves a log before and after a merge).
S = Script
SPEC = [
    ("Tessellate: against Open CASCADE, speed per stage, triangle quality", [
        S("tessellate_vs_occt.py",
          "trimsurf's tessellation against Open CASCADE's mesher at the same MEASURED deviation (eps = 1e-3 x "
          "diagonal; tolerance-only and the defaults): meshing CPU, triangles, angles, on every shared CAD file.",
          "PYTHONPATH=src python benchmarks/tessellate_vs_occt.py [--json out.json]",
          [("tessellate_vs_occt.py", "Latest run")],
          ["**Newest figures (session 29, run at 21:08-21:23 UTC on the 12 comparable files after the developable-face "
           "rule; in the aspect_quality.py section below, \"aspect limit\", \"New tolerance-only ratio\"):** "
           "tolerance-only triangles **0.568x** Open CASCADE's (was 0.645x; aim 0.6x: **met**), CPU time 2.58x "
           "(was 2.62x; aim 3x: met); defaults 1.955x triangles (the same meshes), 3.87x CPU time. The full per-file "
           "table below is session 28's (main 83e5a81).",
           "The earlier runs this one refers to (\"the runs below\") are in HISTORY.md \"tessellate_vs_occt.py\"; "
           "\"shared edges' chord tolerance\" is the per_face_occt.py section below."]),
        S("per_face_occt.py",
          "Where trimsurf's tolerance-only triangles go against Open CASCADE's, face by face and shared edge by "
          "shared edge, for one model.",
          "python benchmarks/per_face_occt.py MODEL LINEAR/EPS ANGULAR",
          [("shared edges' chord tolerance", None)]),
        S("aspect_quality.py",
          "The grid cells' aspect limit (`face.ASPECT`) against Open CASCADE's own triangle quality at the same "
          "measured deviation (issue 17, item 3).",
          "PYTHONPATH=src python benchmarks/aspect_quality.py --comparable --json aq12.json",
          [("aspect limit", None)]),
        S("tessellate_figures.py",
          "The tessellation's figures (deviation, topology, flips, triangles, angles) on every model and both "
          "settings, old tree against new, for a change that MAY change the meshes.",
          "PYTHONPATH=OLD/src python benchmarks/tessellate_figures.py --runs 1 --json old.json; the same with "
          "PYTHONPATH=src and new.json; python benchmarks/tessellate_figures.py --compare old.json new.json",
          [],
          ["Latest run: in the aspect_quality.py section above (\"aspect limit\", session 29, s29-aspect); the "
           "run before it in per_face_occt.py's (\"shared edges' chord tolerance\", session 28)."]),
        S("grid_size.py",
          "Grid size as the paper means it (issue 17, item 4): triangles, longest edge, angles and deviation for "
          "the two readings of the grid-size parameter, adaptive against uniform lines.",
          "python benchmarks/grid_size.py [--models a,b] [--json out.json]",
          [("grid_size.py", None)]),
        S("car_panels.py",
          "Car panels (fender, hood) at the paper's settings (eps = 0.05 mm, grid size 10 mm) against Open "
          "CASCADE (issue 17, item 5).",
          "python benchmarks/car_panels.py [--tolerance 0.05] [--grid-size 10] [--cad panel.step] [--json out.json]",
          [("car_panels.py", None)]),
        S("tessellate_stages.py",
          "CPU time of tessellate_shell's per-face stages (repair, domain values, edges, mesh_faces, ...), "
          "meshing only, best of N runs; run it with each tree on PYTHONPATH to compare.",
          "PYTHONPATH=src python benchmarks/tessellate_stages.py --models featuretype,t20,screw,U_Joint "
          "[--mode paper] [--runs 5]",
          [("Meshing: seams, crossings and the lift", None)]),
        S("tessellate_shell_stages.py",
          "CPU time of tessellate_shell's shell-level stages (assemble, seams, stitch, merge) and of what no "
          "stage holds, best of N runs.",
          "PYTHONPATH=src python benchmarks/tessellate_shell_stages.py --models featuretype,t20,screw,U_Joint,bearing "
          "[--mode paper] [--runs 7]",
          [("shell-level and per-edge Python of the meshing", None)],
          ["The last full table of every shell-level stage: HISTORY.md \"tessellate_shell_stages.py, session 26\"."]),
    ]),
    ("Tessellate: same output, compile and first-call cost (tooling)", [
        S("mesh_identity.py",
          "Same meshes, less time? A hash of what `tessellate_shell` makes of every shared CAD file and sample "
          "(tol and paper settings) and the meshing CPU, one or two source trees.",
          "python benchmarks/mesh_identity.py --src OLD/src --src src [--models a,b] [--json out.json]",
          [("mesh_identity.py", "")],
          ["Each later meshing branch quotes its own mesh_identity.py run in its section (the newest: "
           "tessellate_stages.py's above, session 29)."]),
        S("loose_identity.py",
          "Same loose meshes? Hashes of `tessellate_shell(mode=\"loose\")` on the real files, tol and paper.",
          "PYTHONPATH=OLD/src python benchmarks/loose_identity.py > old.txt; PYTHONPATH=src python "
          "benchmarks/loose_identity.py > new.txt; diff the hash columns",
          [],
          ["Latest run: quoted in HISTORY.md \"tessellate_shell_stages.py, session 26\" (20/20 equal, CPU "
           "0.903-0.984x)."]),
        S("kernel_replay.py",
          "One compiled kernel's calls captured while the shared models are meshed, then replayed under one or "
          "two source trees (outputs checked bit for bit, per-call best times).",
          "python benchmarks/kernel_replay.py capture KERNEL --src OLD/src [--models a,b] [--modes tol,paper]; "
          "python benchmarks/kernel_replay.py replay KERNEL --src OLD/src --src src [--runs 20]",
          [("kernel_replay.py", None)],
          ["Later replays: tessellate_stages.py's section above (seams, clean_pslg, mesh_faces; session 29)."]),
        S("cold_compile.py",
          "Cold numba compile of a first tessellation (occt__screw.step): compile CPU seconds per dispatcher "
          "and its specializations.",
          "rm -rf /tmp/nc_x; NUMBA_CACHE_DIR=/tmp/nc_x PYTHONPATH=$PWD/src python benchmarks/cold_compile.py [measure]",
          [[("cold_compile.py: the cold numba compile back down", None), ("cold_compile.py (s24-cold", None)]],
          ["Each branch that changed a kernel also quotes its own cold-compile figures (e.g. session 29's s29-mesh in "
           "tessellate_stages.py's section above: tessellate 83.46 s on main -> 83.22 s)."]),
        S("first_call.py",
          "First call against warm call per stage, each in fresh processes: what a user of one command waits for.",
          "PYTHONPATH=src python benchmarks/first_call.py --variant new:src --variant main:OLD/src [--cli]",
          [("first_call.py", None)]),
    ]),
    ("Reading", [
        S("read_speed.py",
          "Reading the shared STEP/IGES files into trimsurf's model against Open CASCADE's own read; `--cli`: "
          "the `seconds_read` of `trimsurf tessellate`, tree against tree.",
          "python benchmarks/read_speed.py [--cli --repeats 3 --src OLD/src --src src] [--json out.json]",
          [("read_speed", None)],
          ["The `--cli` run (session 23) is the newest; the last run of the default mode (read_shell against "
           "Open CASCADE in one process) is its last block (\"Earlier\")."]),
        S("read_cost.py",
          "What reading a CAD file costs against meshing it (issue 17, item 2: read at most the meshing time), "
          "fresh processes, one or two trees; `--cache`: repeated reads from the cache of read shells.",
          "python benchmarks/read_cost.py --src OLD/src --src src --reps 3 [--models a,b] [--cache]",
          [("read_cost.py --cache", None)]),
        S("read_identity.py",
          "Same shells from two source trees: every shared CAD file read by each, compared bit for bit.",
          "python benchmarks/read_identity.py --src OLD/src --src src [--in-process]",
          [],
          ["Latest run: quoted in the read_cost.py section above (session 29, s29-read)."]),
    ]),
    ("Measurement (the tessellation report's figures)", [
        S("measure_cost.py",
          "CPU of the report's measurement (`measure_result`) against the meshing itself, tol and defaults, "
          "old tree against new.",
          "PYTHONPATH=src python benchmarks/measure_cost.py --reps 3 --reference OLD/src",
          [("Measurement: where the projections go", None)],
          ["Session 29's warm-started first pass was measured and REVERTED: HISTORY.md \"Measurement: warm-started "
           "first pass\". Sessions 21-27: HISTORY.md \"Tessellation measurement: adaptive deviation sampling\"."]),
        S("measure_same.py",
          "Do two checkouts report the same measurement figures on the same pickled meshes?",
          "PYTHONPATH=OLD/src python benchmarks/measure_same.py meshes DIR; ... figures DIR old.json (each tree); "
          "python benchmarks/measure_same.py compare old.json new.json",
          [],
          ["Latest run: quoted in the measure_cost.py section above (34 / 34 identical, session 28) and in "
           "measure_prep.py's below."]),
        S("measure_prep.py",
          "What the first `measure_result` of a file pays that a second one on the same shell does not (per-file "
          "preparation), fresh processes.",
          "PYTHONPATH=src python benchmarks/measure_prep.py --models U_Joint,featuretype --runs 5 --mode warm "
          "--reference OLD/src",
          [("measure_prep.py: span bounds", None)]),
        S("cli_measure.py",
          "Where `trimsurf tessellate`'s `seconds_measure` goes, old tree against new, fresh CLI processes.",
          "PYTHONPATH=$PWD/src python benchmarks/cli_measure.py --src OLD/src --src $PWD/src --runs 4 [--tol-only]",
          [("cli_measure.py", None)]),
        S("flip_feet.py",
          "The flip test with the deviation's centroid feet against a fresh projection of the corners' mean.",
          "python benchmarks/flip_feet.py DIR (the pickled meshes of measure_same.py)",
          [],
          ["Latest run: quoted in the cli_measure.py section above (session 27)."]),
    ]),
    ("Join", [
        S("join_scaling.py",
          "Joining two mesh patches: time against n (vertices) x sigma (boundary segments per patch).",
          "python benchmarks/join_scaling.py --json out.json",
          [("join_scaling.py", None)]),
        S("join_real.py",
          "Joining real CAD models: accuracy inside the triangles, folding, sewing; Whitney join against the "
          "midpoint baseline.",
          "python benchmarks/join_real.py --json out.json",
          [("join_real.py", "Latest run")]),
    ]),
    ("Certify", [
        S("certify_speed.py",
          "Certifying the shared CAD models: faces certified per second, where the time goes, against Open "
          "CASCADE's B-rep checks.",
          "python benchmarks/certify_speed.py [FILE ...] [--json out.json]",
          [("certify_speed.py", None)]),
    ]),
    ("Reconstruct", [
        S("reconstruct_speed.py",
          "Reconstruction speed: minimum norm network solve and filling at 1K, 10K and 100K vertices.",
          "python benchmarks/reconstruct_speed.py",
          [("reconstruct_speed.py", None)]),
        S("reconstruct_fills.py",
          "G1 error and curvature jump of every reconstruction fill, on the paper's examples and real meshes "
          "(sampled, not bounds).",
          "python benchmarks/reconstruct_fills.py",
          [("reconstruct_fills.py", None)]),
    ]),
    ("Fit", [
        S("fit_quality.py",
          "Fitting trimmed NURBS faces to meshes: every mesh x forward map x back-map, the face written to STEP "
          "and read back (paper Tables 1-6).",
          "python benchmarks/fit_quality.py [--json out.json]",
          [("fit_quality.py", None)]),
    ]),
    ("Geometry evaluation", [
        S("eval_speed.py",
          "NURBS evaluation and closest-point projection speed, against Open CASCADE in the same run.",
          "python benchmarks/eval_speed.py [--json out.json]",
          [("eval_speed", None)]),
    ]),
    ("Viz", [
        S("viz_speed.py",
          "Offscreen PNG time against plain pyvista, HTML page size against glTF, page load in Chromium.",
          "python benchmarks/viz_speed.py [--json out.json]",
          [("viz_speed.py", None)]),
        S("zebra_seams.py",
          "Which seams between CAD faces the zebra shades as smooth, against the exact normals.",
          "python benchmarks/zebra_seams.py [FILE ...]",
          [("zebra_seams.py", None)]),
    ]),
    ("Batch and interop", [
        S("batch_scaling.py",
          "Parts per minute of `trimsurf batch` with 1 and 2 Dask workers, overhead against one process, "
          "projection to 8 / 64 / 512 workers.",
          "PYTHONPATH=src python benchmarks/batch_scaling.py [--jobs tessellate] [--json out.json]",
          [("batch_scaling.py", None)]),
        S("interop_io.py",
          "Interop costs: in-memory Open CASCADE shapes and .brep files against STEP; CAE mesh formats through "
          "meshio.",
          "PYTHONPATH=src python benchmarks/interop_io.py",
          [("interop_io.py", None)]),
    ]),
]

INTRO = """\
This file keeps, per benchmark script of `benchmarks/`, what it measures, the command, and its LATEST
recorded run (table, date, conclusions, copied verbatim from the run's record). Every older run, every
section about a script that no longer exists, and reverted work are in `benchmarks/HISTORY.md`
(per-session records, in the order they were written). `benchmarks/check_results_split.py` made this split
from the session log and checks that no line of it was lost.

How the figures are measured (the project's rule): on the delivered artifact (the triangles written, inside,
not only their vertices; files read back; the continuous surface between samples). Where a bound is sampled
rather than proven, the run says so. Times are process CPU unless a run says wall; the machine has 2 cores
shared with ~7 engineers, so each run states its load average, and speed comparisons interleave the old and
the new tree and keep the best of several runs.

When you rerun a benchmark: replace its block below with your run (command, date, machine load, table,
conclusions) and move the replaced block to HISTORY.md.
"""

HISTORY_INTRO = """\
# Benchmark history

Per-session records of the benchmarks, verbatim, in the order they were written (sessions 1-29): every
run that is no longer the latest of its script, sections about scripts since removed or folded into others
(e.g. chunks_replay.py, place_replay.py, refine_replay.py, mesh_faces_replay.py, span_bounds_micro.py,
seams_replay.py: now `kernel_replay.py`), and reverted work. The newest run of each script is in
`benchmarks/RESULTS.md`; a line "*Latest run moved to RESULTS.md ...*" marks where a block was taken out.
"""


# ---------------------------------------------------------------------------------------------------------
def read_log(log: str) -> list[str]:
    p = Path(log)
    if p.is_file():
        text = p.read_text()
    else:
        text = subprocess.run(["git", "-C", str(ROOT), "show", f"{log}:benchmarks/RESULTS.md"],
                              check=True, capture_output=True, text=True).stdout
    return text.split("\n")


def parse(lines):
    """Preamble lines and sections [heading, [pre lines], [(sub heading, lines)]], code fences respected."""
    fence = False
    pre, secs = [], []
    for line in lines:
        head = None
        if line.startswith("```"):
            fence = not fence
        elif not fence and line.startswith("## "):
            head = 2
        elif not fence and line.startswith("### ") and secs:
            head = 3
        if head == 2:
            secs.append([line, [], []])
        elif head == 3:
            secs[-1][2].append((line, [line]))
        elif not secs:
            pre.append(line)
        elif secs[-1][2]:
            secs[-1][2][-1][1].append(line)
        else:
            secs[-1][1].append(line)
    return pre, secs


def demote(block, by):
    out, fence = [], False
    for line in block:
        if line.startswith("```"):
            fence = not fence
        if not fence and re.match(r"#{1,6} ", line):
            line = "#" * by + line
        out.append(line)
    return out


def strip_blank_ends(block):
    block = list(block)
    while block and not block[0].strip():
        block.pop(0)
    while block and not block[-1].strip():
        block.pop()
    return block


def anchor(title):
    a = re.sub(r"[^\w\- ]", "", title.strip().lower())
    return a.replace(" ", "-")


def build(lines):
    pre, secs = parse(lines)
    title = lambda h: h.lstrip("#").strip()  # noqa: E731
    taken = {}   # (section index, sub index | None | "") -> script name
    blocks = {}  # script name -> list of (block lines, level of its top heading)

    def find(sel):
        if isinstance(sel, list):  # alternatives, newest first: the first one the log holds
            for alt in sel[:-1]:
                if len(hits_of(alt)) == 1:
                    return find(alt)
            return find(sel[-1])
        hits = hits_of(sel)
        if len(hits) != 1:
            sys.exit(f"selector {sel!r} matches {len(hits)} blocks of the log (need exactly 1)")
        return hits[0]

    def hits_of(sel):
        sp, tp = sel
        hits = []
        for i, (h, _, subs) in enumerate(secs):
            if not title(h).startswith(sp):
                continue
            if tp is None or tp == "":
                hits.append((i, tp))
            else:
                hits += [(i, j) for j, (sh, _) in enumerate(subs) if title(sh).startswith(tp)]
        return hits

    for _, scripts in SPEC:
        for sc in scripts:
            for sel in sc.latest:
                key = find(sel)
                if key in taken:
                    sys.exit(f"{sel!r} taken by both {taken[key]} and {sc.name}")
                taken[key] = sc.name
                i, j = key
                h, body, subs = secs[i]
                if j is None:
                    blk = [h] + body + [ln for _, sub in subs for ln in sub]
                    blocks.setdefault(sc.name, []).append((blk, 2))
                elif j == "":
                    blocks.setdefault(sc.name, []).append(([h] + body, 2))
                else:
                    blocks.setdefault(sc.name, []).append((subs[j][1], 3))

    names = sorted(p.name for p in BENCH.glob("*.py") if p.name != Path(__file__).name)
    spec_names = [sc.name for _, scripts in SPEC for sc in scripts]
    missing = set(names) - set(spec_names)
    gone = set(spec_names) - set(names)
    if missing or gone:
        sys.exit(f"SPEC out of date: scripts without a section {sorted(missing)}, sections without a script "
                 f"{sorted(gone)}")

    # RESULTS.md
    out = list(strip_blank_ends(pre)) + [""] + INTRO.split("\n")
    out += ["## Contents", ""]
    for g, scripts in SPEC:
        out.append(f"- [{g}](#{anchor(g)}): " + ", ".join(f"[{sc.name}](#{anchor(sc.name)})" for sc in scripts))
    out.append("")
    for g, scripts in SPEC:
        out += [f"## {g}", ""]
        for sc in scripts:
            out += [f"### {sc.name}", "", textwrap.fill(sc.what, 115), "", f"Command: `{sc.command}`", ""]
            for n in sc.notes:
                out += [textwrap.fill(n, 115, break_on_hyphens=False), ""]
            if not sc.latest and not sc.notes:
                out += ["No recorded run.", ""]
            for blk, level in blocks.get(sc.name, []):
                out += demote(strip_blank_ends(blk), 4 - level) + [""]
    results = "\n".join(out).rstrip("\n") + "\n"

    # HISTORY.md
    hist = HISTORY_INTRO.split("\n")
    unassigned = []
    for i, (h, body, subs) in enumerate(secs):
        if (i, None) in taken:
            continue
        if (i, "") in taken:
            hist += [h, "", f"*Latest run moved to RESULTS.md \"{taken[(i, '')]}\" (this section's opening part).*", ""]
        else:
            hist += [h] + body
            if not any((i, j) in taken for j in range(len(subs))):
                unassigned.append(title(h))
        for j, (sh, sub) in enumerate(subs):
            if (i, j) in taken:
                hist += [f"*Latest run moved to RESULTS.md \"{taken[(i, j)]}\": {title(sh)}*", ""]
            else:
                hist += sub
    history = "\n".join(hist).rstrip("\n") + "\n"
    return results, history, unassigned


def add_sections(lines, other):
    """`lines` with the sections of `other` whose heading `lines` lacks appended (a branch's new sections)."""
    have = {h for h, _, _ in parse(lines)[1]}
    new = []
    for h, body, subs in parse(other)[1]:
        if h not in have:
            new += [h] + body + [ln for _, sub in subs for ln in sub]
            print(f"added from the branch: {h}")
    return strip_blank_ends(lines) + [""] + new if new else lines


def norm(line):
    """A line as compared: a heading without its level, and a run superseded by hand ("Previous run",
    the docstring's convention) as the "Latest run" the log called it."""
    line = re.sub(r"^#{1,6} ", "", line).rstrip()
    return "Latest run" + line[len("Previous run"):] if line.startswith("Previous run") else line


def check(lines, results, history):
    old = collections.Counter(norm(x) for x in lines if x.strip())
    new = collections.Counter(norm(x) for x in (results + history).split("\n") if x.strip())
    lost = old - new
    extra = sum((new - old).values())
    print(f"log: {sum(old.values())} non-empty lines ({len(old)} distinct); RESULTS.md + HISTORY.md: "
          f"{sum(new.values())} non-empty lines; lost: {sum(lost.values())}; added (intro, headings, pointers): "
          f"{extra}")
    for line, n in lost.items():
        print(f"LOST x{n}: {line[:120]}")
    # HISTORY.md keeps the log's order: its lines that the log has are a subsequence of the log
    log_set, it, in_order = set(lines), iter(lines), True
    for x in history.split("\n"):
        if x.strip() and x in log_set and not any(y == x for y in it):
            print(f"HISTORY.md out of the log's order at: {x[:120]}")
            in_order = False
            break
    r = [x for x in results.split("\n") if x.strip()]
    h = [x for x in history.split("\n") if x.strip()]
    print(f"RESULTS.md: {len(results.splitlines())} lines ({len(r)} non-empty); HISTORY.md: "
          f"{len(history.splitlines())} lines ({len(h)} non-empty); HISTORY.md in the log's order: {in_order}")
    return not lost and in_order


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("action", choices=["split", "check"])
    ap.add_argument("--log", default=DEFAULT_LOG, help="git revision or file holding the session log")
    ap.add_argument("--add-from", action="append", default=[], metavar="REV_OR_FILE",
                    help="append to the log the '## ' sections this RESULTS.md (a branch still writing the log "
                         "form) has and the log has not, in its order; repeatable")
    a = ap.parse_args(argv)
    lines = read_log(a.log)
    for src in a.add_from:
        lines = add_sections(lines, read_log(src))
    if a.action == "split":
        results, history, unassigned = build(lines)
        (BENCH / "RESULTS.md").write_text(results)
        (BENCH / "HISTORY.md").write_text(history)
        for u in unassigned:
            print(f"history: {u}")
        ok = check(lines, results, history)
    else:
        results = (BENCH / "RESULTS.md").read_text()
        history = (BENCH / "HISTORY.md").read_text()
        ok = check(lines, results, history)
        want_r, want_h, _ = build(lines)
        if (want_r, want_h) != (results, history):
            print("RESULTS.md / HISTORY.md differ from what `split` makes of this log (edited by hand, or a "
                  "newer log: rerun split with --log)")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())

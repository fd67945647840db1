"""``OUT/index.html``: one self-contained page over the parts of a batch, sortable, with zebra thumbnails."""

from __future__ import annotations

import base64
import html
from pathlib import Path

__all__ = ["write_index"]

#: worst first when sorting by status
_STATUS_RANK = {"failed": 0, "not_met": 1, "ok": 2}

_STYLE = """
body{font-family:system-ui,sans-serif;margin:1.5em;color:#222}
table{border-collapse:collapse;font-size:14px}
th,td{border-bottom:1px solid #ddd;padding:4px 8px;text-align:left;vertical-align:middle}
th.sort{cursor:pointer;user-select:none;background:#f3f3f3}
th.sort:after{content:" \\2195";color:#999}
td.num{text-align:right;font-variant-numeric:tabular-nums}
td.status{white-space:nowrap}
.ok{color:#17692b;font-weight:600}.not_met{color:#9a6200;font-weight:600}.failed{color:#b00020;font-weight:600}
.reason{max-width:32em;font-size:12px;color:#555}
img.thumb{width:160px;height:120px;object-fit:contain;background:#eee;display:block}
.nothumb{width:160px;height:120px;background:#eee;display:flex;align-items:center;justify-content:center;color:#999}
"""

_SCRIPT = """
document.querySelectorAll('th.sort').forEach(function(th){
  th.addEventListener('click',function(){
    var table=th.closest('table'),body=table.tBodies[0],col=th.cellIndex;
    var asc=th.dataset.dir!=='asc';th.dataset.dir=asc?'asc':'desc';
    var rows=Array.prototype.slice.call(body.rows);
    rows.sort(function(a,b){
      var x=parseFloat(a.cells[col].dataset.v),y=parseFloat(b.cells[col].dataset.v);
      if(isNaN(x))x=Infinity;if(isNaN(y))y=Infinity;
      return asc?x-y:y-x;});
    rows.forEach(function(r){body.appendChild(r);});
  });
});
"""


def _num(v, fmt: str) -> str:
    return "-" if v is None else format(v, fmt)


def _thumb(part_dir: Path) -> str:
    p = part_dir / "thumb.png"
    if not p.is_file():
        return '<div class="nothumb">no picture</div>'
    data = base64.b64encode(p.read_bytes()).decode("ascii")
    return f'<img class="thumb" alt="zebra" src="data:image/png;base64,{data}">'


def _links(part: str, part_dir: Path) -> str:
    names = [("view.html", "viewer"), ("zebra.png", "zebra"), ("tessellate.json", "tessellate report"),
             ("certify.json", "certificate"), ("mesh.ply", "mesh")]
    return " &middot; ".join(f'<a href="{html.escape(part)}/{n}">{label}</a>' for n, label in names
                             if (part_dir / n).is_file()) or "-"


def write_index(rows: list[dict], out: str | Path, *, jobs: tuple[str, ...]) -> None:
    """Write ``OUT/index.html`` from the rows of the results table (one table row per part).

    Self-contained: the thumbnails are inlined (data URIs), the sorting is a few
    lines of inline script; links point at each part's files under ``OUT/<part>/``.
    Sortable columns: status (worst of the part's jobs), max deviation, time.
    """
    from ..io._atomic import atomic_path

    out = Path(out)
    parts: dict[str, dict[str, dict]] = {}
    for r in rows:
        parts.setdefault(r["part"], {})[r["job"]] = r
    counts = {s: sum(r["status"] == s for r in rows) for s in _STATUS_RANK}
    head = ["picture", "part", "status", "triangles", "max deviation", "flips", "watertight", "certified faces",
            "time (s)", "links", "reasons"]
    sortable = {"status", "max deviation", "time (s)", "triangles"}
    lines = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
             "<title>trimsurf batch</title>", f"<style>{_STYLE}</style></head><body>",
             f"<h1>trimsurf batch: {len(parts)} parts</h1>",
             "<p>jobs: " + html.escape(", ".join(jobs)) + " &mdash; "
             + ", ".join(f'<span class="{s}">{counts[s]} {s}</span>' for s in _STATUS_RANK)
             + ' (rows of <a href="results.csv">results.csv</a>, <a href="results.parquet">results.parquet</a>).'
             " Click a grey heading to sort.</p>",
             "<table><thead><tr>"
             + "".join(f'<th class="sort">{h}</th>' if h in sortable else f"<th>{h}</th>" for h in head)
             + "</tr></thead><tbody>"]
    for part, by_job in parts.items():
        part_dir = out / part
        statuses = [r["status"] for r in by_job.values()]
        worst = min(statuses, key=lambda s: _STATUS_RANK.get(s, -1))
        tess = by_job.get("tessellate") or by_job.get("view") or {}
        cert = by_job.get("certify") or {}
        seconds = sum(r["seconds"] or 0.0 for r in by_job.values())
        faces = cert.get("faces") or tess.get("faces")
        certified = "-" if cert.get("certified_faces") is None else f"{cert['certified_faces']}/{faces}"
        job_status = " ".join(f'<span class="{r["status"]}" title="{html.escape(j)}">{html.escape(j)}: '
                              f'{html.escape(r["status"])}</span><br>' for j, r in by_job.items())
        reasons = "<br>".join(f"{html.escape(j)}: {html.escape(r['reason'])}" for j, r in by_job.items()
                              if r.get("reason"))
        dev = tess.get("max_deviation")
        cells = [
            f"<td>{_thumb(part_dir)}</td>",
            f'<td title="{html.escape(str(tess.get("input") or ""))}">{html.escape(part)}</td>',
            f'<td class="status" data-v="{_STATUS_RANK.get(worst, -1)}">{job_status}</td>',
            f'<td class="num" data-v="{tess.get("triangles") if tess.get("triangles") is not None else ""}">'
            f'{_num(tess.get("triangles"), "d")}</td>',
            f'<td class="num" data-v="{"" if dev is None else repr(float(dev))}">{_num(dev, ".3g")}</td>',
            f'<td class="num">{_num(tess.get("flips"), "d")}</td>',
            f'<td>{"-" if tess.get("watertight") is None else ("yes" if tess["watertight"] else "no")}</td>',
            f"<td>{certified}</td>",
            f'<td class="num" data-v="{seconds!r}">{seconds:.1f}</td>',
            f"<td>{_links(part, part_dir)}</td>",
            f'<td class="reason">{reasons}</td>']
        lines.append("<tr>" + "".join(cells) + "</tr>")
    lines += ["</tbody></table>", f"<script>{_SCRIPT}</script>",
              "</body></html>"]
    with atomic_path(out / "index.html") as tmp:
        tmp.write_text("\n".join(lines) + "\n", encoding="utf-8")

"""``atlas.html``: the atlas as one self-contained page (inline SVG and script, nothing
fetched): a heat map of δ per panel (the layout of :mod:`optdesign.atlas.charts`), and beside
it the cell under the pointer: its rules, verdict, δ, ratio, relative lengths, what binds,
and its linkage drawn at φ1 = 0 from the mechanism's own joints
(:func:`optdesign.figures.design.linkage`)."""
from __future__ import annotations

import html
import json
import math
from pathlib import Path

from optdesign.atlas.charts import LABELS, SHORT, layout, panel_title, panels
from optdesign.evaluation.design import Design
from optdesign.figures.design import linkage
from optdesign.outputs.atomic import atomic_write_text

#: viridis at five stops (reversed: small δ bright), for the cells' colours
STOPS = ((253, 231, 37), (94, 201, 98), (33, 145, 140), (59, 82, 139), (68, 1, 84))
CELL = 34          # px of a cell's side


def shade(delta: float, lo: float, hi: float) -> float:
    """Where ``delta`` lies between ``lo`` and ``hi`` on a log scale, in [0, 1] (the map's
    colours: δ spans a factor of five or more over an atlas)."""
    if hi <= lo or delta <= 0:
        return 0.0
    return math.log(delta / lo) / math.log(hi / lo)


def colour(t: float) -> str:
    """The colour of ``t`` in [0, 1] on :data:`STOPS`."""
    t = min(1.0, max(0.0, t)) * (len(STOPS) - 1)
    k = min(int(t), len(STOPS) - 2)
    a, b = STOPS[k], STOPS[k + 1]
    return "#" + "".join(f"{round(u + (v - u) * (t - k)):02x}" for u, v in zip(a, b))


def drawing(spec, rec: dict) -> dict | None:
    """The linkage of a feasible cell at φ1 = 0: joints and links with their roles."""
    if not rec["feasible"]:
        return None
    design = Design(spec.mechanism, dict(rec["design"]), dict(spec.base.get("options", {})))
    link = linkage(design, n_angles=24)
    at = link.at(0.0)
    return {"joints": {k: [round(float(v[0]), 5), round(float(v[1]), 5)]
                       for k, v in at.items()},
            "links": [[a, b, link.roles[(a, b)]] for a, b in link.links]}


def cell_data(spec, rec: dict) -> dict:
    return {"values": rec["values"], "status": rec["status"], "delta": rec["delta"],
            "ratio": rec["ratio"], "angle": rec.get("min_transmission_angle_deg"),
            "design": {k: rec["design"].get(k) for k in spec.lengths} if rec["design"] else {},
            "binding": rec.get("binding", ""), "message": rec.get("message", ""),
            "drawing": drawing(spec, rec)}


def _panel_svg(spec, where: dict, recs: list[dict], lo: float, hi: float) -> str:
    x, y, _ = layout(spec)
    xs, ys = list(spec.axes[x]), list(spec.axes[y]) if y else [None]
    left, top = 56, 8
    width, height = left + CELL * len(xs) + 8, top + CELL * len(ys) + 44
    parts = [f'<svg width="{width}" height="{height}" role="img">']
    for r in recs:
        j = xs.index(r["values"][x])
        i = len(ys) - 1 - (ys.index(r["values"][y]) if y else 0)
        cx, cy = left + CELL * j, top + CELL * i
        if r["feasible"]:
            fill = colour(shade(r["delta"], lo, hi))
            text = f"{r['delta']:.3f}"[1:]
            ink = "#000" if shade(r["delta"], lo, hi) < 0.5 else "#fff"
        else:
            fill, text, ink = "url(#hatch)", "×", "#555"
        parts.append(f'<rect class="cell" data-cell="{r["cell"]}" x="{cx}" y="{cy}" '
                     f'width="{CELL - 2}" height="{CELL - 2}" fill="{fill}"/>'
                     f'<text x="{cx + CELL / 2 - 1}" y="{cy + CELL / 2 + 3}" fill="{ink}" '
                     f'font-size="9" text-anchor="middle" pointer-events="none">{text}</text>')
    for j, v in enumerate(xs):
        parts.append(f'<text x="{left + CELL * j + CELL / 2 - 1}" y="{top + CELL * len(ys) + 12}"'
                     f' font-size="10" text-anchor="middle">{html.escape(_fmt(v))}</text>')
    for i, v in enumerate(ys):
        yy = top + CELL * (len(ys) - 1 - i) + CELL / 2 + 3
        parts.append(f'<text x="{left - 6}" y="{yy}" font-size="10" text-anchor="end">'
                     f'{html.escape(_fmt(v))}</text>')
    parts.append(f'<text x="{left + CELL * len(xs) / 2}" y="{top + CELL * len(ys) + 30}" '
                 f'font-size="11" text-anchor="middle">{html.escape(LABELS[x])}</text>')
    if y:
        parts.append(f'<text x="12" y="{top + CELL * len(ys) / 2}" font-size="11" '
                     f'text-anchor="middle" transform="rotate(-90 12 {top + CELL * len(ys) / 2})"'
                     f'>{html.escape(SHORT[y])}</text>')
    parts.append("</svg>")
    return (f'<figure><figcaption>{html.escape(panel_title(where))}</figcaption>'
            f'{"".join(parts)}</figure>')


def _fmt(v) -> str:
    return "" if v is None else v if isinstance(v, str) else f"{v:g}"


def page(result) -> str:
    """The whole page as text."""
    spec = result.spec
    feasible = [r["delta"] for r in result.records if r["feasible"]]
    lo, hi = (min(feasible), max(feasible)) if feasible else (0.0, 1.0)
    figures = "".join(_panel_svg(spec, where, recs, lo, hi) for where, recs in panels(result))
    data = json.dumps({"cells": {r["cell"]: cell_data(spec, r) for r in result.records},
                       "relative_to": spec.regulated}, allow_nan=False)
    data = data.replace("</", "<\\/")
    fixed = ", ".join(f"{k} = {_fmt(v)}" for k, v in spec.fixed.items())
    legend = "".join(f'<span style="background:{colour(t)};color:{"#000" if t < 0.5 else "#fff"}">'
                     f'&nbsp;{lo * (hi / lo) ** t:.3f}&nbsp;</span>'
                     for t in (0, 0.25, 0.5, 0.75, 1))
    return _TEMPLATE.format(title=html.escape(spec.name), name=html.escape(spec.name),
                            mechanism=html.escape(spec.mechanism), reg=spec.regulated,
                            fixed=html.escape(fixed), n=len(result.records),
                            feasible=result.n_feasible, legend=legend, figures=figures,
                            data=data)


def write_page(result, out) -> Path:
    """atlas.html in ``out``, atomically."""
    return atomic_write_text(Path(out) / "atlas.html", page(result))


_TEMPLATE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{title}: design atlas</title>
<style>
body {{ font-family: sans-serif; margin: 16px; color: #222; }}
#wrap {{ display: flex; gap: 24px; align-items: flex-start; }}
#maps {{ display: flex; flex-wrap: wrap; gap: 8px; max-width: 62%; }}
figure {{ margin: 0; }} figcaption {{ font-size: 12px; font-weight: bold; }}
rect.cell {{ cursor: pointer; stroke: #fff; }} rect.cell:hover {{ stroke: #000; stroke-width: 2; }}
#info {{ position: sticky; top: 8px; min-width: 300px; font-size: 13px; }}
#info table td {{ padding: 1px 6px; }}
.legend span {{ font-size: 11px; }}
</style></head><body>
<h2>{name}: least ripple δ, lengths relative to {reg}</h2>
<p>{mechanism}; {n} cells, {feasible} feasible; fixed: {fixed}. Hover a cell for its design
(× hatched: infeasible). Every length below is a multiple of {reg}: scale to your crank.</p>
<p class="legend">δ: {legend}</p>
<svg width="0" height="0" style="position:absolute"><defs><pattern id="hatch" width="6"
height="6" patternUnits="userSpaceOnUse" patternTransform="rotate(45)"><rect width="6"
height="6" fill="#ddd"/><line x1="0" y1="0" x2="0" y2="6" stroke="#999" stroke-width="2"/>
</pattern></defs></svg>
<div id="wrap"><div id="maps">{figures}</div>
<div id="info"><em>hover a cell</em></div></div>
<script type="application/json" id="atlas-data">{data}</script>
<script>
const atlas = JSON.parse(document.getElementById("atlas-data").textContent);
const colours = {{crank: "#d62728", rocker: "#1f77b4", coupler: "#555", frame: "#bbb"}};
function fmt(v, d) {{ return v === null || v === undefined ? "-" :
  (typeof v === "number" ? (Number.isInteger(v) ? String(v) : v.toFixed(d)) : String(v)); }}
function esc(t) {{ return String(t).replace(/[&<>"]/g, c => ({{"&": "&amp;", "<": "&lt;",
  ">": "&gt;", '"': "&quot;"}})[c]); }}
function draw(d) {{
  if (!d) return "<p><em>no design: infeasible</em></p>";
  const pts = Object.values(d.joints);
  const xs = pts.map(p => p[0]), ys = pts.map(p => p[1]);
  const x0 = Math.min(...xs), x1 = Math.max(...xs), y0 = Math.min(...ys), y1 = Math.max(...ys);
  const s = 260 / Math.max(x1 - x0, y1 - y0, 1e-9);
  const X = p => 10 + (p[0] - x0) * s, Y = p => 10 + (y1 - p[1]) * s;
  let out = `<svg id="drawing" width="${{(x1 - x0) * s + 20}}" height="${{(y1 - y0) * s + 20}}">`;
  for (const [a, b, role] of d.links) {{
    const p = d.joints[a], q = d.joints[b];
    out += `<line x1="${{X(p)}}" y1="${{Y(p)}}" x2="${{X(q)}}" y2="${{Y(q)}}" ` +
      `stroke="${{colours[role] || "#555"}}" stroke-width="${{role === "crank" ? 3 : 1.5}}"/>`;
  }}
  for (const p of pts) out += `<circle cx="${{X(p)}}" cy="${{Y(p)}}" r="2.5" fill="#222"/>`;
  return out + "</svg>";
}}
function show(i) {{
  const c = atlas.cells[i];
  const row = (k, v) => `<tr><td>${{k}}</td><td>${{v}}</td></tr>`;
  let rows = Object.entries(c.values).map(([k, v]) => row(esc(k), esc(fmt(v, 4)))).join("");
  rows += row("status", `<b>${{esc(c.status)}}</b>`);
  rows += row("δ", fmt(c.delta, 6)) + row("ratio", fmt(c.ratio, 4));
  rows += row("least angle", `${{fmt(c.angle, 2)}} deg`);
  for (const [k, v] of Object.entries(c.design))
    rows += row(`${{esc(k)}} / ${{atlas.relative_to}}`, fmt(v, 4));
  rows += `<tr><td>binding</td><td>${{esc(c.binding || "-")}}</td></tr>`;
  const note = c.message ? `<p>${{esc(c.message)}}</p>` : "";
  document.getElementById("info").innerHTML =
    `<h3>cell ${{i}}</h3><table>${{rows}}</table>${{note}}${{draw(c.drawing)}}`;
}}
document.querySelectorAll("rect.cell").forEach(r =>
  r.addEventListener("mouseenter", () => show(r.dataset.cell)));
const first = Object.keys(atlas.cells).find(k => atlas.cells[k].status === "optimal");
if (first !== undefined) show(first);
</script></body></html>
"""

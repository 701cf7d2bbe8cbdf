"""The linkage over one crank turn: a self-contained HTML page and a GIF.

Each frame is the linkage at one crank angle (:func:`~optdesign.figures.design.linkage`), the
rocker that drives the output there highlighted: the member whose driving speed s·dθ_k/dφ is
the envelope's (Sharkov & Kalinin 2022, eqs. 5-8), beside the output speed over the turn with
the frame's angle marked. The HTML page holds its data and its script inline (no file or
network beside it) and draws with SVG; the GIF is drawn by matplotlib and written by Pillow, as
matplotlib's PillowWriter writes it (its frames rendered by two processes at once), and an MP4
with matplotlib's ffmpeg writer when ffmpeg is on the PATH.
"""
from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np

from optdesign.envelope.sampled import STROKE_SIGNS, driving_speeds
from optdesign.figures.design import ZOOM_BELOW, linkage

#: frames of one crank turn
FRAMES = 120
#: colours of the roles (those of the DXF's layers), and the driving rocker's
COLOURS = {"frame": "#8c8c8c", "crank": "#d62728", "coupler": "#1f4fd6",
           "rocker": "#2a8a2a", "driving": "#ff7f0e"}


@dataclass(frozen=True)
class Turn:
    """What every frame shows: joint positions, the links and their roles, the member each
    rocker link is, which member drives at each frame, and the speeds."""

    names: tuple[str, ...]
    positions: np.ndarray            # (frames, joints, 2), mm
    links: tuple                     # ((a, b, role, member or None), ...)
    phi_deg: np.ndarray              # (frames,)
    driving: np.ndarray              # (frames,) member index driving the output
    speeds: np.ndarray               # (members, frames) driving speed s·ω_k, rad/s (best sign)
    output: np.ndarray               # (frames,) output speed, rad/s
    #: the output speed at each eccentricity shown beside the drawn one: ((label, (frames,)
    #: rad/s), ...), each label naming its δ (:mod:`optdesign.evaluation.ripples`)
    outputs: tuple = ()
    eccentricity: float = 1.0        # the drawn linkage's
    crank_pivot: str | None = None   # the crank's fixed pivot, and its reach [mm]
    crank_reach: float = 0.0

    def to_dict(self) -> dict:
        return {"names": list(self.names),
                "positions": np.round(self.positions, 4).tolist(),
                "links": [list(link) for link in self.links],
                "phi": np.round(self.phi_deg, 4).tolist(),
                "driving": self.driving.tolist(),
                "speeds": np.round(self.speeds, 5).tolist(),
                "output": np.round(self.output, 5).tolist(),
                "eccentricity": self.eccentricity,
                "crank": {"pivot": self.crank_pivot, "reach": round(self.crank_reach, 4)},
                "outputs": [{"label": label, "speed": np.round(speed, 5).tolist()}
                            for label, speed in self.outputs]}


def turn(design, stroke: str, input_speed: float, eccentricity: float = 1.0,
         frames: int = FRAMES, outputs: tuple = ()) -> Turn:
    """The :class:`Turn` of ``design`` over ``frames`` crank angles; ``outputs``: ((e,
    label), ...), the eccentricities whose output speed is drawn too, each labelled."""
    drawn = linkage(design, eccentricity, frames)
    phi = np.linspace(0.0, 2 * np.pi, frames, endpoint=False)
    kin = design.sample(phi, eccentricity)
    count = kin["dtheta"].shape[0]
    curves = driving_speeds(kin["dtheta"], stroke) * input_speed        # (signs·members, N)
    best = curves.argmax(axis=0)
    output = np.maximum(curves.max(axis=0), 0.0)
    per_member = curves.reshape(len(STROKE_SIGNS[stroke]), count, frames).max(axis=0)
    members = _rocker_members(drawn, kin["theta"])
    pivot = drawn.crank_pivot
    frame = tuple((pivot, j, "frame", None) for j in sorted(drawn.fixed - {pivot})
                  if pivot is not None)               # the frame from the crank's pivot
    links = frame + tuple((a, b, role, members.get((a, b)))
                          for (a, b), role in drawn.roles.items())
    positions = drawn.turn.transpose(0, 2, 1)                           # (frames, joints, 2)
    shown = tuple((label, output if e == eccentricity else
                   output_speed(design, stroke, input_speed, e, phi)) for e, label in outputs)
    return Turn(drawn.names, positions, links, np.degrees(phi), best % count, per_member,
                output, shown, float(eccentricity), pivot, drawn.crank_reach())


def output_speed(design, stroke: str, input_speed: float, eccentricity: float,
                 phi: np.ndarray) -> np.ndarray:
    """The output speed [rad/s] of ``design`` at ``eccentricity`` over the crank angles
    ``phi``."""
    curves = driving_speeds(design.sample(phi, eccentricity)["dtheta"], stroke) * input_speed
    return np.maximum(curves.max(axis=0), 0.0)


def _rocker_members(drawn, theta: np.ndarray) -> dict:
    """Rocker link -> the output member whose angle θ_k it turns with (the least spread of
    their wrapped difference over the turn)."""
    out = {}
    for (a, b), role in drawn.roles.items():
        if role != "rocker":
            continue
        pivot, end = (a, b) if a in drawn.fixed else (b, a)
        v = drawn.path(end) - drawn.path(pivot)
        angle = np.arctan2(v[:, 1], v[:, 0])
        spread = [np.abs(np.angle(np.exp(1j * (angle - t)) /
                                  np.mean(np.exp(1j * (angle - t))))).max() for t in theta]
        out[(a, b)] = int(np.argmin(spread))
    return out


# --------------------------------------------------------------------------- HTML
def html_page(data: Turn, title: str) -> str:
    """The self-contained page: an SVG of the linkage and one of the speeds, a script that
    turns the crank, a button to pause."""
    low = data.positions.reshape(-1, 2).min(axis=0)
    high = data.positions.reshape(-1, 2).max(axis=0)
    pad = 0.06 * float(max(high - low))
    box = [float(low[0] - pad), float(-high[1] - pad), float(high[0] - low[0] + 2 * pad),
           float(high[1] - low[1] + 2 * pad)]
    top = float(max([data.speeds.max(), data.output.max()] +
                    [speed.max() for _, speed in data.outputs])) * 1.08 or 1.0
    payload = json.dumps(data.to_dict() | {"colours": COLOURS, "top": top,
                                           "width": box[2]}, separators=(",", ":"))
    height = str(300 + 18 * len(data.outputs))
    detail = ""
    if data.crank_pivot is not None and 0 < data.crank_reach < ZOOM_BELOW * box[2]:
        centre = data.positions[0, data.names.index(data.crank_pivot)]
        half = 3 * data.crank_reach
        detail = (f'<div><div>crank detail (× {box[2] / (2 * half):.0f})</div><svg id="detail" '
                  f'width="240" height="240" viewBox="{centre[0] - half:.4f} '
                  f'{-centre[1] - half:.4f} {2 * half:.4f} {2 * half:.4f}"></svg></div>')
    return _PAGE.replace("__HEIGHT__", height).replace("__TITLE__", _escape(title)).replace(
        "__VIEWBOX__", " ".join(f"{x:.4f}" for x in box)).replace(
        "__DETAIL__", detail).replace("__DATA__", payload)


def _escape(text: str) -> str:
    return (text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
            .replace('"', "&quot;"))


_PAGE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>__TITLE__</title>
<style>
body{font-family:system-ui,sans-serif;margin:16px;color:#222;background:#fff}
.row{display:flex;flex-wrap:wrap;gap:16px;align-items:flex-start}
svg{border:1px solid #ddd;background:#fff}
#state{font-variant-numeric:tabular-nums;margin:8px 0}
button{font-size:14px;padding:4px 12px}
.key span{display:inline-block;width:18px;height:4px;margin:0 4px 3px 12px}
</style></head><body>
<h2>__TITLE__</h2>
<div class="key"><span style="background:#d62728"></span>crank<span
style="background:#1f4fd6"></span>couplers<span style="background:#2a8a2a"></span>rockers<span
style="background:#ff7f0e"></span>the rocker driving the output<span
style="background:#8c8c8c"></span>frame</div>
<div id="state">&nbsp;</div>
<button id="toggle">pause</button>
<div class="row">
<svg id="linkage" width="560" height="560" viewBox="__VIEWBOX__"></svg>
__DETAIL__
<svg id="speeds" width="560" height="__HEIGHT__" viewBox="0 0 560 __HEIGHT__"></svg>
</div>
<script>
const D = __DATA__;
const NS = "http://www.w3.org/2000/svg";
const L = document.getElementById("linkage"), S = document.getElementById("speeds");
const Z = document.getElementById("detail");
const idx = {}; D.names.forEach((n, i) => idx[n] = i);
function el(parent, tag, attrs) {
  const e = document.createElementNS(NS, tag);
  for (const k in attrs) e.setAttribute(k, attrs[k]);
  parent.appendChild(e); return e;
}
// the linkage, and the crank detail (a small crank magnified) when there is one
const views = [[L, D.width / 280]];
if (Z) views.push([Z, Z.viewBox.baseVal.width / 110]);
const w = views[0][1];
const width = (role, w) => w * (role === "frame" ? 0.7 : role === "coupler" ? 1.2 : 2);
const drawn = views.map(([V, w]) => {
  if (D.crank.pivot !== null) el(V, "circle", {cx: D.positions[0][idx[D.crank.pivot]][0],
    cy: -D.positions[0][idx[D.crank.pivot]][1], r: D.crank.reach, fill: "none",
    stroke: D.colours.crank, "stroke-width": w * 0.6, "stroke-dasharray": (3 * w) + "," + (2 * w)});
  return {w: w, lines: D.links.map(([a, b, role]) => el(V, "line", {stroke: D.colours[role],
    "stroke-width": width(role, w), "stroke-linecap": "round",
    "stroke-dasharray": role === "frame" ? (4 * w) + "," + (3 * w) : "none"})),
  dots: D.names.map(() => el(V, "circle", {r: w * 2.2, fill: "#fff", stroke: "#333",
    "stroke-width": w * 0.6}))};
});
const x0 = 48, x1 = 548, y0 = 262, y1 = 24;
const sx = p => x0 + (x1 - x0) * p / 360, sy = v => y0 - (y0 - y1) * Math.max(v, 0) / D.top;
el(S, "line", {x1: x0, y1: y0, x2: x1, y2: y0, stroke: "#999"});
el(S, "line", {x1: x0, y1: y0, x2: x0, y2: y1, stroke: "#999"});
[0, 90, 180, 270, 360].forEach(p => { const t = el(S, "text", {x: sx(p), y: y0 + 16,
  "font-size": 11, "text-anchor": "middle"}); t.textContent = p + "\u00b0"; });
const yl = el(S, "text", {x: x1, y: 12, "font-size": 11, "text-anchor": "end"});
yl.textContent = "output speed (black) and each member's driving speed, rad/s";
const xl = el(S, "text", {x: (x0 + x1) / 2, y: y0 + 29, "font-size": 11,
  "text-anchor": "middle"}); xl.textContent = "crank angle";
const ticks = [0, D.top / 2, D.top];
ticks.forEach(v => { const t = el(S, "text", {x: x0 - 4, y: sy(v) + 4, "font-size": 10,
  "text-anchor": "end"}); t.textContent = v.toFixed(1); });
const path = ys => ys.map((v, i) => sx(D.phi[i]) + "," + sy(v)).join(" ");
D.speeds.forEach(ys => el(S, "polyline", {points: path(ys), fill: "none",
  stroke: "#2a8a2a", "stroke-opacity": 0.35, "stroke-width": 1}));
const OC = ["#111", "#1f77b4", "#d62728", "#9467bd", "#8c564b"];
const OD = ["none", "6,3", "2,2", "8,3,2,3", "4,4"];
D.outputs.forEach((o, i) => { el(S, "polyline", {points: path(o.speed), fill: "none",
  stroke: OC[i % 5], "stroke-width": 2, "stroke-dasharray": OD[i % 5]});
  el(S, "line", {x1: x0, y1: 300 + 18 * i, x2: x0 + 28, y2: 300 + 18 * i, stroke: OC[i % 5],
    "stroke-width": 2, "stroke-dasharray": OD[i % 5]});
  const t = el(S, "text", {x: x0 + 34, y: 304 + 18 * i, "font-size": 11, "class": "output"});
  t.textContent = o.label; });
if (!D.outputs.length) el(S, "polyline", {points: path(D.output), fill: "none",
  stroke: "#111", "stroke-width": 2.2});
const cursor = el(S, "line", {y1: y0, y2: y1, stroke: "#ff7f0e", "stroke-width": 1.5});
const mark = el(S, "circle", {r: 4, fill: "#ff7f0e"});
const state = document.getElementById("state");
let frame = 0, running = true, shown = 0;
function draw(f) {
  const P = D.positions[f];
  drawn.forEach(({w, lines, dots}) => {
    D.links.forEach(([a, b, role, member], i) => {
      const p = P[idx[a]], q = P[idx[b]], ln = lines[i];
      ln.setAttribute("x1", p[0]); ln.setAttribute("y1", -p[1]);
      ln.setAttribute("x2", q[0]); ln.setAttribute("y2", -q[1]);
      const drives = role === "rocker" && member === D.driving[f];
      ln.setAttribute("stroke", drives ? D.colours.driving : D.colours[role]);
      ln.setAttribute("stroke-width", drives ? w * 3.4 : width(role, w));
    });
    D.names.forEach((n, i) => { dots[i].setAttribute("cx", P[i][0]);
      dots[i].setAttribute("cy", -P[i][1]); });
  });
  cursor.setAttribute("x1", sx(D.phi[f])); cursor.setAttribute("x2", sx(D.phi[f]));
  mark.setAttribute("cx", sx(D.phi[f])); mark.setAttribute("cy", sy(D.output[f]));
  state.textContent = "e = " + D.eccentricity + " \u00b7 crank angle " + D.phi[f].toFixed(1) + "\u00b0 \u00b7 member " +
    (D.driving[f] + 1) + " drives \u00b7 output " + D.output[f].toFixed(3) + " rad/s";
  document.body.setAttribute("data-frames-shown", ++shown);
}
document.getElementById("toggle").onclick = function () {
  running = !running; this.textContent = running ? "pause" : "play"; };
let last = 0;
function tick(t) {
  if (running && t - last > 1000 / 24) { draw(frame); frame = (frame + 1) % D.phi.length;
    last = t; }
  requestAnimationFrame(tick);
}
draw(0); requestAnimationFrame(tick);
</script></body></html>
"""


# --------------------------------------------------------------------------- GIF / MP4
def movie(data: Turn, title: str, path, fps: int = 24) -> None:
    """The turn as a GIF (``path`` ending .gif) or an MP4 (.mp4, needs ffmpeg), drawn by
    matplotlib: the linkage on the left, the speeds on the right."""
    import matplotlib
    from matplotlib.animation import FFMpegWriter, FuncAnimation

    from optdesign.figures.design import pyplot

    plt = pyplot()
    with matplotlib.rc_context({"figure.dpi": 80}):
        fig, (ax, bx) = plt.subplots(1, 2, figsize=(10, 4.6),
                                     gridspec_kw={"width_ratios": [1, 1.25]})
    low = data.positions.reshape(-1, 2).min(axis=0)
    high = data.positions.reshape(-1, 2).max(axis=0)
    pad = 0.05 * float(max(high - low))
    ax.set_xlim(low[0] - pad, high[0] + pad)
    ax.set_ylim(low[1] - pad, high[1] + pad)
    ax.set_aspect("equal")
    ax.set_axis_off()
    drawn = [ax.plot([], [], color=COLOURS[role], lw=_width(role), ls="--" if role == "frame"
                     else "-", solid_capstyle="round")[0] for _, _, role, _ in data.links]
    joints = ax.plot([], [], "o", ms=3, mfc="white", mec="0.2")[0]
    for ys in data.speeds:
        bx.plot(data.phi_deg, ys, color=COLOURS["rocker"], alpha=0.35, lw=0.9)
    if data.outputs:
        for i, (label, speed) in enumerate(data.outputs):
            bx.plot(data.phi_deg, speed, color="black" if i == 0 else f"C{i - 1}", lw=1.8,
                    ls=("-", "--", "-.", ":")[i % 4], label=label)
        bx.legend(fontsize=7, loc="lower center", bbox_to_anchor=(0.5, 1.0), frameon=False)
    else:
        bx.plot(data.phi_deg, data.output, color="black", lw=2)
    top = float(max([data.speeds.max(), data.output.max()] +
                    [speed.max() for _, speed in data.outputs])) * 1.08 or 1.0
    bx.set_ylim(0, top)
    bx.set_xlim(0, 360)
    bx.set_xticks(range(0, 361, 90))
    bx.set_xlabel(f"crank angle φ1 [deg] (the linkage at e = {data.eccentricity:g})")
    bx.set_ylabel("speed [rad/s]")
    bx.grid(alpha=0.3)
    cursor = bx.axvline(0, color=COLOURS["driving"], lw=1.2)
    mark = bx.plot([], [], "o", color=COLOURS["driving"], ms=5)[0]
    fig.suptitle(title, fontsize=10)
    index = {n: i for i, n in enumerate(data.names)}

    def frame(f):
        P = data.positions[f]
        for line, (a, b, role, member) in zip(drawn, data.links):
            p, q = P[index[a]], P[index[b]]
            line.set_data([p[0], q[0]], [p[1], q[1]])
            drives = role == "rocker" and member == data.driving[f]
            line.set_color(COLOURS["driving"] if drives else COLOURS[role])
            line.set_linewidth(3.6 if drives else _width(role))
        joints.set_data(P[:, 0], P[:, 1])
        cursor.set_xdata([data.phi_deg[f]] * 2)
        mark.set_data([data.phi_deg[f]], [data.output[f]])
        return [*drawn, joints, cursor, mark]

    # Saving renders each frame once, for the file. Without blitting, FuncAnimation also asks
    # the canvas to redraw after each frame, and an Agg canvas renders the whole figure again
    # for nothing shown (half the movie's time): this figure is never shown, so it does not.
    fig.canvas.draw_idle = lambda *args, **kwargs: None
    try:
        if str(path).endswith(".gif"):
            _gif(fig, frame, len(data.phi_deg), path, fps)
        else:
            FuncAnimation(fig, frame, frames=len(data.phi_deg), blit=False).save(
                str(path), writer=FFMpegWriter(fps=fps))
    finally:
        plt.close(fig)


def _gif(fig, draw_frame, count: int, path, fps: int) -> None:
    """The GIF of frames ``0 .. count - 1`` (``draw_frame(f)`` sets the figure to frame f), the
    file matplotlib's PillowWriter writes, byte for byte, in about half its time: the frames
    are rendered and reduced to their palettes by two processes at once, the first half here
    and the second in a child forked beside (:func:`optdesign.lifetime.beside`; here too where
    no child can be forked), and Pillow writes them as one file, as PillowWriter does."""
    from optdesign.lifetime import beside

    half = (count + 1) // 2
    second = beside(_palette_frames, fig, draw_frame, range(half, count), fps)
    frames = _palette_frames(fig, draw_frame, range(half), fps) + second()
    frames[0].save(path, save_all=True, append_images=frames[1:], duration=int(1000 / fps),
                   loop=0)


def _palette_frames(fig, draw_frame, indices, fps: int) -> list:
    """The frames ``indices`` as matplotlib's PillowWriter grabs them (the figure saved as
    RGBA at the writer's dpi; an opaque one as RGB), each opaque one reduced to the adaptive
    palette Pillow's GIF writer gives it: the images that writer writes."""
    import io

    from matplotlib.animation import AbstractMovieWriter, FuncAnimation
    from PIL import Image

    class Kept(AbstractMovieWriter):
        """A movie writer that keeps its frames (GIF-ready) and writes no file."""

        def setup(self, fig, outfile, dpi=None):
            super().setup(fig, outfile, dpi=dpi)
            self.frames = []

        def grab_frame(self, **savefig_kwargs):
            buf = io.BytesIO()
            self.fig.savefig(buf, **{**savefig_kwargs, "format": "rgba", "dpi": self.dpi})
            rgba = Image.frombuffer("RGBA", self.frame_size, buf.getbuffer(), "raw", "RGBA",
                                    0, 1)
            if rgba.getextrema()[3][0] < 255:   # see-through: Pillow's GIF writer reduces it
                self.frames.append(rgba)
            else:                               # opaque: as RGB, reduced as that writer does
                self.frames.append(rgba.convert("RGB").convert("P",
                                                               palette=Image.Palette.ADAPTIVE))

        def finish(self):
            pass

    kept = Kept(fps=fps)
    FuncAnimation(fig, draw_frame, frames=list(indices), blit=False).save(
        "frames.gif", writer=kept)
    return kept.frames


def _width(role: str) -> float:
    """A link's line width in the movie, by its role."""
    return {"frame": 0.7, "coupler": 1.2}.get(role, 2.2)


def turn_title(problem, design, figures, named=None) -> str:
    """The page's and the movie's title: the name, the count, the problem's δ named
    (``named``: :class:`optdesign.evaluation.ripples.Ripples`; else the δ of ``figures``,
    named by its eccentricity) and the ratio."""
    from optdesign.evaluation.ripples import Ripple

    count = problem.model.count_variable
    delta = named.worst if named is not None else \
        Ripple(figures.ripple(problem.objective.ripple), problem.objective.ripple, None)
    return (f"{problem.name}: {problem.mechanism}, {count} = {design.count}, "
            f"{delta.text(4)}, ratio = {figures.ratio:.4f}")

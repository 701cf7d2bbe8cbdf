"""Figures of a design: rocker speeds with the output envelope, and drawings of the linkage.

Plot functions take data, accept ``ax=None`` and return the figure; matplotlib is imported
only here, and only when a plot is made.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from optdesign.envelope.sampled import STROKE_SIGNS, output_envelope


def pyplot():
    """matplotlib.pyplot, imported on first use. The backend is never switched here: a
    notebook keeps its own (the ``optdesign`` command selects Agg, files only, before any
    figure is made)."""
    import matplotlib.pyplot as plt
    return plt


def warm_up(problem=None) -> None:
    """Import pyplot and draw one small figure with text on an Agg canvas of its own (no
    backend chosen, nothing written): the first figure of a process pays for loading the
    fonts and the renderer, and a process that draws later
    (:class:`optdesign.outputs.figure_process.FigureProcess`) pays it while it waits.

    With ``problem``, also build what the figures of its designs evaluate, for each of its
    counts (:func:`_build_kinematics`): the design is not known yet, its mechanism is; and
    import the exact evaluator's searches (SciPy's root finder and bounded minimiser), which
    those figures call (each design's δ in its labels): SciPy's optimisation package takes half
    a second to import, which each figure, forked from this process, paid again after the
    answer (``benchmarks/command_latency.py``)."""
    pyplot()
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(1, 1))
    fig.text(0.5, 0.5, "φ1 [deg]")
    FigureCanvasAgg(fig).draw()
    if problem is not None:
        _build_kinematics(problem)
        import scipy.optimize  # noqa: F401 - the exact evaluator's brentq and minimize_scalar


def _build_kinematics(problem) -> None:
    """The joints (:func:`linkage`) and the kinematics as lanes (:func:`plot_speeds`) of
    each count of ``problem``, built once in this process (they are cached): 0.05-0.1 s a
    count, fewer than a solve spends on each."""
    from optdesign.evaluation.design import Design

    for count in problem.counts():
        design = Design.from_problem(problem, {problem.model.count_variable: count})
        design.model.joints(count, design.option_key)
        try:
            design.model.kinematic_lanes(count, design.option_key)
        except NotImplementedError:         # sampled by CasADi's map instead
            pass


def plot_speeds(design, stroke: str, input_speed: float, eccentricity: float = 1.0,
                ax=None, n_samples: int = 1441, title: str | None = None,
                outputs: list[tuple[float, str]] | None = None):
    """Each rocker's driving speed s·ω_k over the crank angle at ``eccentricity``, and the
    output envelope there; with ``outputs`` ([(e, label), ...], e.g. each listed
    eccentricity labelled with its δ by :mod:`optdesign.evaluation.ripples`), the output
    envelope at each of those eccentricities instead, each with its label."""
    plt = pyplot()
    fig, ax = (ax.figure, ax) if ax is not None else plt.subplots(figsize=(8, 4.5))
    phi = np.linspace(0, 2 * np.pi, n_samples)
    dtheta = design.sample(phi, eccentricity)["dtheta"]
    deg = np.degrees(phi)
    for s in STROKE_SIGNS[stroke]:
        for k in range(dtheta.shape[0]):
            ax.plot(deg, s * dtheta[k] * input_speed, lw=0.9, alpha=0.6,
                    label=f"member {k + 1}" if s == STROKE_SIGNS[stroke][0] else None)
    shown = outputs or [(eccentricity, "output (envelope)")]
    styles = ["-", "--", "-.", ":"]
    top, bottom = 0.0, 0.0
    for i, (e, label) in enumerate(shown):
        at = dtheta if e == eccentricity else design.sample(phi, e)["dtheta"]
        env = output_envelope(at, stroke) * input_speed
        line, = ax.plot(deg, env, color="black" if i == 0 else f"C{i - 1}", lw=2.4,
                        ls=styles[i % len(styles)], label=label)
        for y in (env.min(), env.max()):
            ax.axhline(y, color=line.get_color(), ls=":", lw=0.8)
        top, bottom = max(top, env.max()), min(bottom, env.min())
    ax.set_ylim(bottom - 0.05 * top, top * 1.08)
    ax.set_xlim(0, 360)
    ax.set_xticks(range(0, 361, 45))
    ax.set_xlabel("crank angle φ1 [deg]")
    ax.set_ylabel("driving speed [rad/s]" if stroke == "both" else
                  f"speed in the {stroke} direction [rad/s]")
    ax.set_title(title or f"{stroke} stroke, eccentricity {eccentricity:g}")
    ax.grid(alpha=0.3)
    if not outputs:
        ax.legend(fontsize=7, ncol=5, loc="upper center", bbox_to_anchor=(0.5, -0.14),
                  frameon=False)
        return fig
    # the outputs' labels are long: one line each, under the members' legend
    members = dtheta.shape[0]
    handles, labels = ax.get_legend_handles_labels()
    rows = -(-members // 6)
    ax.add_artist(ax.legend(handles[:members], labels[:members], fontsize=7,
                            ncol=min(6, members), loc="upper center",
                            bbox_to_anchor=(0.5, -0.14), frameon=False,
                            title=f"each member's driving speed at e = {eccentricity:g}",
                            title_fontsize=7))
    ax.legend(handles[members:], labels[members:], fontsize=8, ncol=1, loc="upper center",
              bbox_to_anchor=(0.5, -0.2 - 0.045 * rows), frameon=False)
    return fig


# --------------------------------------------------------------------------- the linkage
#: how each kind of link is drawn (and named in the legend)
LINK_STYLE = {"crank": {"color": "crimson", "lw": 3.4, "label": "crank"},
              "coupler": {"color": "tab:blue", "lw": 1.7, "label": "couplers / rods"},
              "rocker": {"color": "tab:green", "lw": 2.4, "label": "rockers"},
              "frame": {"color": "0.45", "lw": 1.2, "ls": "-.", "label": "frame"}}
#: a crank smaller than this fraction of the drawing gets a panel of its own, magnified
ZOOM_BELOW = 1 / 6


@dataclass(frozen=True)
class Linkage:
    """A design's joints over one crank turn, and the part each joint and link plays.

    Read from the mechanism's ``joints`` function alone, so any mechanism is drawn the same
    way: a joint that never moves is a fixed pivot; a link from a fixed pivot whose direction
    turns with the crank angle is a crank, any other link from a fixed pivot a rocker, a
    link between two moving joints a coupler or rod.
    """

    names: tuple[str, ...]
    links: tuple[tuple[str, str], ...]
    turn: np.ndarray                 # joint positions over the turn, (angles, 2, joints) [mm]
    fixed: frozenset
    roles: dict                      # link -> crank | rocker | coupler | frame
    position: object                 # (crank angle [deg]) -> {joint: (x, y)}

    def at(self, angle_deg: float) -> dict[str, np.ndarray]:
        return self.position(angle_deg)

    def ends(self, role: str) -> list[str]:
        """The moving joints of the links playing ``role``, each once."""
        out = []
        for link, r in self.roles.items():
            out += [j for j in link if r == role and j not in self.fixed and j not in out]
        return out

    def path(self, joint: str) -> np.ndarray:
        """(angles, 2) positions of ``joint`` over the turn."""
        return self.turn[:, :, self.names.index(joint)]

    @property
    def crank_pivot(self) -> str | None:
        return next((j for link, r in self.roles.items() if r == "crank" for j in link
                     if j in self.fixed), None)

    def crank_reach(self) -> float:
        """Farthest distance of a crank end from the crank pivot over the turn [mm]."""
        pivot = self.crank_pivot
        if pivot is None:
            return 0.0
        return max(float(np.nanmax(np.hypot(*(self.path(j) - self.path(pivot)).T)))
                   for j in self.ends("crank"))

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower-left and upper-right corners of everything the turn sweeps [mm]."""
        xy = self.turn.transpose(0, 2, 1).reshape(-1, 2)
        return np.nanmin(xy, axis=0), np.nanmax(xy, axis=0)


def linkage(design, eccentricity: float = 1.0, n_angles: int = 360) -> Linkage:
    """The :class:`Linkage` of ``design`` sampled at ``n_angles`` crank angles."""
    fn, names, links = design.model.joints(design.count, design.option_key)
    p = design.p(eccentricity)
    phi = np.linspace(0.0, 2 * np.pi, n_angles, endpoint=False)
    turn = np.array(fn.map(n_angles)(phi[None, :], p)).reshape(2, n_angles, len(names))
    turn = turn.transpose(1, 0, 2)
    scale = float(np.nanmax(np.abs(turn))) or 1.0
    moved = np.nanmax(np.abs(turn - turn[:1]), axis=(0, 1))
    fixed = frozenset(k for k, m in zip(names, moved) if m <= 1e-9 * scale)
    roles = {}
    for a, b in links:
        if a in fixed and b in fixed:
            roles[(a, b)] = "frame"
        elif a in fixed or b in fixed:
            pivot, end = (a, b) if a in fixed else (b, a)
            v = turn[:, :, names.index(end)] - turn[:, :, names.index(pivot)]
            ok = np.hypot(*v.T) > 1e-9 * scale
            # the direction follows the crank angle (mod 180°: a slotted crank passes its pivot)
            turns = np.abs(np.mean(np.exp(2j * (np.arctan2(v[ok, 1], v[ok, 0]) - phi[ok]))))
            roles[(a, b)] = "crank" if ok.sum() > 2 and turns > 1 - 1e-6 else "rocker"
        else:
            roles[(a, b)] = "coupler"

    def position(angle_deg):
        return dict(zip(names, np.array(fn(np.radians(angle_deg), p)).T))

    return Linkage(tuple(names), tuple(map(tuple, links)), turn, fixed, roles, position)


def plot_mechanism(design, angles_deg=(0, 90, 180, 270), eccentricity: float = 1.0,
                   axes=None, title: str | None = None):
    """The linkage to scale, in mm, with its joints named and its lengths tabulated.

    Without ``axes``: a large drawing at the first crank angle with the crank circle and each
    rocker's swing over a full turn, a magnified panel of the crank when it is small beside
    the rods, the legend, the lengths and phase count, and one small drawing per further
    angle. With ``axes`` (one per angle): the full drawing in each, the legend and the
    lengths in the first. Returns the figure.
    """
    if axes is None:
        return mechanism_figure(design, angles_deg, eccentricity, title)
    angles = list(angles_deg)
    link = linkage(design, eccentricity)
    axes = np.atleast_1d(axes)
    for ax, angle in zip(axes, angles):
        _draw(ax, link, angle)
        _frame(ax, link, f"φ1 = {angle:g}°")
        _name_joints(ax, link, angle, link.names)
    axes[0].legend(handles=_legend_handles(link, design, eccentricity), fontsize=7,
                   loc="best")
    axes[0].text(0.01, 0.01, _lengths_text(design, eccentricity), fontsize=7,
                 family="monospace", transform=axes[0].transAxes, va="bottom",
                 bbox={"fc": "white", "ec": "0.6", "alpha": 0.9})
    if title:
        axes[0].figure.suptitle(title, fontsize=11)
    return axes[0].figure


#: the bands of :func:`plot_mechanism`'s own figure, one above the other: the drawing at the
#: first angle with its detail, legend and table (and the title); the small drawings
BANDS = ("upper", "lower")


def mechanism_figure(design, angles_deg=(0, 90, 180, 270), eccentricity: float = 1.0,
                     title: str | None = None, bands=BANDS):
    """:func:`plot_mechanism`'s figure of its own, or only the panels of ``bands`` (a part of
    :data:`BANDS`), each where it is in the whole figure: the bands can be drawn by two
    processes at once and joined (:func:`optdesign.outputs.split_figure.save_split`)."""
    plt = pyplot()
    angles = list(angles_deg)
    link = linkage(design, eccentricity)
    lo, hi = link.bounds()
    reach = link.crank_reach()
    zoom = 0 < reach < ZOOM_BELOW * float(np.max(hi - lo))
    fig, panels = _panels(plt, (hi - lo)[1] / max((hi - lo)[0], 1e-9), zoom, len(angles) - 1,
                          bands)
    if "upper" in bands:
        _upper_band(fig, panels, link, design, angles[0], eccentricity, (lo, hi, reach),
                    title)
    for ax, angle in zip(panels["thumbs"], angles[1:]):
        _draw(ax, link, angle, paths=False)
        _frame(ax, link, f"φ1 = {angle:g}°", small=True)
    return fig


def _upper_band(fig, panels, link: Linkage, design, angle: float, eccentricity: float,
                extent: tuple, title: str | None) -> None:
    """The drawing at ``angle`` (the crank detail where its panel is), the legend, the
    lengths and the title; ``extent``: the linkage's bounds and crank reach, as measured for
    the panels."""
    lo, hi, reach = extent
    zoom = "detail" in panels
    pose = link.at(angle)
    pivot = pose.get(link.crank_pivot, np.zeros(2))
    window = (pivot - 3 * reach, pivot + 3 * reach)
    main = panels["main"]
    _draw(main, link, angle)
    _frame(main, link, f"φ1 = {angle:g}°",
           window=(np.fmin(lo, window[0]), np.fmax(hi, window[1])) if zoom else None)
    inside = [k for k, xy in pose.items()
              if zoom and np.all(np.abs(xy - pivot) < 3 * reach)]
    if zoom:
        from matplotlib.patches import Rectangle

        detail = panels["detail"]
        _draw(detail, link, angle)
        _frame(detail, link, "crank detail", window=window)
        main.add_patch(Rectangle(window[0], *(window[1] - window[0]), fill=False, ec="0.35",
                                 lw=0.9, ls="--", zorder=3))
        main.annotate("crank detail", (window[1][0], window[0][1]), fontsize=7.5,
                      color="0.35", xytext=(2, 2), textcoords="offset points", va="bottom")
        _name_joints(detail, link, angle, inside, centre=pivot)
    _name_joints(main, link, angle, [k for k in link.names if k not in inside],
                 avoid=[pose[k] for k in inside])
    panels["keys"].axis("off")
    panels["keys"].legend(handles=_legend_handles(link, design, eccentricity),
                          loc="center left", fontsize=8.5, frameon=False)
    _lengths_table(panels["table"], design, eccentricity)
    fig.suptitle(title or f"{design.mechanism}, {design.model.count_variable} = "
                          f"{design.count}", fontsize=12, y=1 - 0.25 / fig.get_figheight())


def _panels(plt, aspect: float, zoom: bool, n_thumbs: int, bands=BANDS):
    """The figure and its axes: the main drawing, the crank detail (with ``zoom``), the
    legend, the lengths table (the upper band) and ``n_thumbs`` small drawings (the lower),
    of the ``bands`` asked for (the others' places left empty).

    Sizes follow the drawing's height/width ``aspect``: a round converter gets the side
    column beside it, a flat slotted lever the detail, legend and table in a row below.
    """
    aspect = float(np.clip(aspect, 0.25, 1.2))
    flat = aspect < 0.6
    heights = ([11.5 * aspect + 0.8, 3.0 if zoom else 1.8] if flat else
               [max(8.0 * aspect, 5.6)])
    if n_thumbs:
        thumb = 13.0 / max(n_thumbs, 3) * 0.85 * aspect
        heights.append(float(np.clip(thumb, 1.2, 2.6)) + 0.9)
    fig = plt.figure(figsize=(13, sum(heights) + 0.8))
    outer = fig.add_gridspec(len(heights), 1 if flat else 2, height_ratios=heights,
                             width_ratios=None if flat else [2.2, 1], left=0.06, right=0.98,
                             bottom=0.05, top=1 - 0.8 / fig.get_figheight(),
                             wspace=0.14, hspace=0.25)
    panels = {"thumbs": []}
    if "upper" in bands:
        n_side = 3 if zoom else 2
        side = (outer[1, 0].subgridspec(1, n_side, wspace=0.3) if flat else
                outer[0, 1].subgridspec(n_side, 1, hspace=0.3,
                                        height_ratios=[1.3, 0.75, 0.8] if zoom else [1, 1]))
        panels |= {"main": fig.add_subplot(outer[0, 0]),
                   "keys": fig.add_subplot(side[-2]), "table": fig.add_subplot(side[-1])}
        if zoom:
            panels["detail"] = fig.add_subplot(side[0])
    if n_thumbs and "lower" in bands:
        row = outer[-1, :].subgridspec(1, max(n_thumbs, 3), wspace=0.25)
        panels["thumbs"] = [fig.add_subplot(row[j]) for j in range(n_thumbs)]
    return fig, panels


def _draw(ax, link: Linkage, angle: float, paths: bool = True) -> None:
    """Links, joints and (with ``paths``) the crank circle and rocker swings at one angle."""
    if paths:
        for j in link.ends("crank"):
            ax.plot(*_closed(link.path(j)).T, color="crimson", lw=0.9, ls="--", alpha=0.8,
                    zorder=1)
        for j in (j for j in link.ends("rocker") if j not in link.ends("crank")):
            ax.plot(*_closed(link.path(j)).T, color="tab:green", lw=1.3, ls=":", zorder=1)
    pts = link.at(angle)
    for (a, b), role in link.roles.items():
        style = {k: v for k, v in LINK_STYLE[role].items() if k != "label"}
        ax.plot(*np.c_[pts[a], pts[b]], solid_capstyle="round",
                zorder=3 if role == "crank" else 2, **style)      # the crank never hidden
    # one line of markers for the fixed pivots, one for the moving joints: each marker drawn
    # as it would be alone, in the same order (a line's markers are stamped one by one)
    fixed = [k in link.fixed for k in pts]
    xy = np.array(list(pts.values()), dtype=float).reshape(-1, 2)
    ax.plot(*xy[fixed].T, "^", ms=9, color="black", zorder=4)
    ax.plot(*xy[np.logical_not(fixed)].T, "o", ms=5.5, mfc="white", mec="black", mew=1.1,
            zorder=5)


def _closed(path: np.ndarray) -> np.ndarray:
    """A path over the turn with its first point repeated: the loop drawn without a gap."""
    return np.vstack([path, path[:1]])


def _frame(ax, link: Linkage, heading: str, window=None, small: bool = False) -> None:
    """Equal scales in mm, the limits of the whole turn (or ``window``), labelled axes."""
    lo, hi = window if window is not None else link.bounds()
    pad = 0.07 * float(np.max(hi - lo))
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    size = 7 if small else 8.5
    ax.set_xlabel("x [mm]", fontsize=size)
    ax.set_ylabel("y [mm]", fontsize=size)
    ax.tick_params(labelsize=size - 1)
    ax.set_title(heading, fontsize=size + 1)
    ax.grid(alpha=0.25)


def _name_joints(ax, link: Linkage, angle: float, names, centre=None, avoid=()) -> None:
    """Each joint's name beside it, pointing away from ``centre`` (the drawing's middle)."""
    pts = link.at(angle)
    names = [k for k in names if np.all(np.isfinite(pts[k]))]
    if not names:
        return
    if centre is None:
        centre = np.mean(link.bounds(), axis=0)
    xy = np.array([pts[k] for k in names])
    d = xy - centre
    prefer = [np.arctan2(y, x) if np.hypot(x, y) > 1e-9 else -0.75 * np.pi for x, y in d]
    place_labels(ax, xy, names, prefer=prefer, avoid=np.array(avoid).reshape(-1, 2),
                 fontsize=9.5, distance=6, fontstyle="italic",     # italic: "O" is no pin
                 bbox={"boxstyle": "round,pad=0.12", "fc": "white", "ec": "none",
                       "alpha": 0.8})


def _legend_handles(link: Linkage, design, eccentricity: float) -> list:
    from matplotlib.lines import Line2D

    roles = set(link.roles.values())
    handles = [Line2D([], [], **LINK_STYLE[r]) for r in LINK_STYLE if r in roles]
    handles += [Line2D([], [], ls="none", marker="^", ms=9, color="black", label="fixed pivots"),
                Line2D([], [], ls="none", marker="o", ms=5.5, mfc="white", mec="black",
                       label="moving joints")]
    reg = design.model.regulating_variable
    if link.ends("crank"):
        handles.append(Line2D([], [], color="crimson", lw=0.9, ls="--",
                              label=f"crank circle ({reg} = "
                                    f"{design.values[reg] * eccentricity:.4g} mm)"))
    if any(j not in link.ends("crank") for j in link.ends("rocker")):
        handles.append(Line2D([], [], color="tab:green", lw=1.3, ls=":",
                              label="rocker swing over a turn"))
    return handles


def _length_rows(design, eccentricity: float) -> list[list[str]]:
    model, reg = design.model, design.model.regulating_variable
    rows = []
    for k in model.lengths:
        v = design.values[k]
        rows.append([k, f"{v:.2f}" + (f" (× e {eccentricity:g} = {v * eccentricity:.2f})"
                                      if k == reg and eccentricity != 1.0 else "")])
    return rows + [[model.count_variable, f"{design.count}"]]


def _lengths_table(ax, design, eccentricity: float) -> None:
    ax.axis("off")
    rows = _length_rows(design, eccentricity)
    table = ax.table(cellText=rows, colLabels=["design key", "value"], loc="upper center",
                     cellLoc="right", colLoc="center", colWidths=[0.42, 0.55])
    table.auto_set_font_size(False)
    table.set_fontsize(9)
    table.scale(1, 1.25)
    ax.set_title(f"lengths [mm] and {design.model.count_variable}", fontsize=9.5)


def _lengths_text(design, eccentricity: float) -> str:
    return "\n".join(f"{k:<9}{v:>9}" for k, v in _length_rows(design, eccentricity))


# --------------------------------------------------------------------------- labels
def place_labels(ax, points, texts, colors=None, prefer=None, avoid=(), force=True,
                 fontsize: float = 8.0, distance: float = 6.0, **text_style):
    """Write each text beside its data point where it overlaps no other label, no marker of
    ``points`` or ``avoid`` and stays inside the axes; returns the Text objects (None where a
    label found no free place and ``force`` is false).

    Tries 16 directions at one then two ``distance`` (points) away, nearest the preferred
    direction first (``prefer``: radians per point, default up-right). With ``force`` a label
    that finds no free place goes where it overlaps least. Place labels once the axes' size and
    limits are final: the offsets are in points, the overlaps measured in pixels.
    """
    ax.apply_aspect()
    scale = ax.figure.dpi / 72.0
    xy = ax.transData.transform(np.asarray(points, dtype=float).reshape(-1, 2))
    others = [ax.transData.transform(np.asarray(avoid, dtype=float).reshape(-1, 2))] \
        if len(avoid) else []
    markers = np.vstack([xy] + others)
    frame = ax.get_window_extent()
    placed, out = [], []
    for i, (text, p) in enumerate(zip(texts, xy)):
        start = np.pi / 4 if prefer is None else prefer[i]
        turns = sorted(np.arange(16) * np.pi / 8, key=lambda a: abs(np.angle(
            np.exp(1j * (a - start)))))
        label = ax.annotate(text, points[i], xytext=(0, 0), textcoords="offset points",
                            fontsize=fontsize, zorder=6,
                            color=None if colors is None else colors[i], **text_style)
        best = (np.inf, None)
        for reach in (distance, 2 * distance):
            for a in turns:
                dx, dy = reach * np.cos(a), reach * np.sin(a)
                label.set_position((dx, dy))
                label.set_ha("left" if dx > 0.3 * reach else "right" if dx < -0.3 * reach
                             else "center")
                label.set_va("bottom" if dy > 0.3 * reach else "top" if dy < -0.3 * reach
                             else "center")
                box = label.get_window_extent()
                cost = _overlap(box, placed, markers, 4.0 * scale, exclude=p) + \
                    _outside(box, frame)
                if cost < best[0]:
                    best = (cost, (dx, dy, label.get_ha(), label.get_va()))
                if cost == 0:
                    break
            if best[0] == 0:
                break
        if best[0] > 0 and not force:
            label.remove()
            out.append(None)
            continue
        dx, dy, ha, va = best[1]
        label.set_position((dx, dy))
        label.set_ha(ha)
        label.set_va(va)
        placed.append(label.get_window_extent())
        out.append(label)
    return out


def _overlap(box, placed, markers, half: float, exclude) -> float:
    """Area (px²) that ``box`` shares with the placed label boxes and the marker squares."""
    area = sum(_shared(box, b.x0, b.y0, b.x1, b.y1) for b in placed)
    near = markers[(markers[:, 0] > box.x0 - half) & (markers[:, 0] < box.x1 + half) &
                   (markers[:, 1] > box.y0 - half) & (markers[:, 1] < box.y1 + half)]
    for m in near:
        if not np.allclose(m, exclude):
            area += _shared(box, m[0] - half, m[1] - half, m[0] + half, m[1] + half)
    return area


def _shared(box, x0, y0, x1, y1) -> float:
    return max(0.0, min(box.x1, x1) - max(box.x0, x0)) * \
        max(0.0, min(box.y1, y1) - max(box.y0, y0))


def _outside(box, frame) -> float:
    """Area of ``box`` outside the axes, weighted so a label never leaves the axes cheaply."""
    inside = _shared(box, frame.x0, frame.y0, frame.x1, frame.y1)
    return 10.0 * (box.width * box.height - inside)


# --------------------------------------------------------------------------- regulation
def plot_regulation(curve: dict, worst: dict | None = None, title: str | None = None):
    """δ and the ratio of a design against the eccentricity e (``analysis.regulation_curve``):
    the regulation interval shaded, the listed eccentricities marked, and the worst e of the
    interval (``worst``: ``AnalysisResult.regulation_range``) with its δ."""
    plt = pyplot()
    fig, (ax_d, ax_r) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    e = curve["eccentricity"]
    ax_d.plot(e, curve["delta"], color="black", lw=1.8)
    ax_r.plot(e, curve["ratio"], color="tab:blue", lw=1.8)
    interval = curve.get("interval")
    for ax in (ax_d, ax_r):
        if interval is not None:
            ax.axvspan(*interval, color="tab:orange", alpha=0.12, label="regulation interval")
        else:
            for x in curve.get("listed", ()):
                ax.axvline(x, color="tab:orange", ls="--", lw=0.9)
        ax.grid(alpha=0.3)
    if worst is not None:
        ax_d.plot([worst["worst_eccentricity"]], [worst["delta"]], "o", color="crimson",
                  label=f"worst: δ = {worst['delta']:.5f} at e = "
                        f"{worst['worst_eccentricity']:.4f}")
    if interval is not None or worst is not None:
        ax_d.legend(fontsize=8)
    ax_d.set_ylabel(f"δ ({curve.get('ripple', 'midrange')})")
    ax_r.set_ylabel("ratio (output / input speed)")
    ax_r.set_xlabel("eccentricity e (fraction of the regulated length)")
    ax_d.set_title(title or "ripple and ratio against the eccentricity")
    fig.tight_layout()
    return fig


def plot_envelopes(curves: dict, ax=None, title: str | None = None):
    """The output speed over the crank angle of several designs, overlaid: ``curves`` maps a
    label to (crank angle [deg], output speed [rad/s])."""
    plt = pyplot()
    fig, ax = (ax.figure, ax) if ax is not None else plt.subplots(figsize=(9, 4.8))
    for label, (deg, speed) in curves.items():
        ax.plot(deg, speed, lw=1.8, label=label)
    ax.set_xlim(0, 360)
    ax.set_xticks(range(0, 361, 45))
    ax.set_xlabel("crank angle φ1 [deg]")
    ax.set_ylabel("output speed [rad/s]")
    ax.set_title(title or "output speed over one crank turn")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.14), frameon=False)
    return fig

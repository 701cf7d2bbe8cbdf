"""The explorer's page: Panel widgets and Bokeh plots around a :class:`Session`.

One layout serves the browser (``optdesign explore``, :mod:`optdesign.explorer.command`) and
the notebook (``optdesign.explore``): a slider with a number field for every free length,
the count, the drawn eccentricity and every constraint's bound; the linkage to scale at the
crank angle of a play control; each rocker's speed and the output speed at each listed
eccentricity; δ as ``solve`` names it, the ratio, the least transmission angle, every
quantity and every constraint's margin (red where violated); re-optimise, follow, save; and
with a front, its points (a click loads the point's design).

Every change is evaluated at once by the exact evaluator (:mod:`optdesign.explorer.snapshot`);
a fault is one line in the page (``message``), never a traceback, and the page keeps
serving.
"""
from __future__ import annotations

import html
import math
from pathlib import Path

import numpy as np

from optdesign.errors import OptDesignError
from optdesign.explorer.snapshot import FRAMES

#: the colours of the linkage's roles (those of ``optdesign animate`` and the DXF layers)
ROLE_COLOURS = {"frame": "#8c8c8c", "crank": "#d62728", "coupler": "#1f4fd6",
                "rocker": "#2a8a2a"}
ROLE_WIDTHS = {"frame": 1.5, "crank": 5.0, "coupler": 2.5, "rocker": 3.5}
MEMBER_COLOURS = ["#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd", "#8c564b", "#e377c2",
                  "#17becf", "#bcbd22", "#7f7f7f", "#d62728", "#aec7e8", "#ffbb78"]
OUTPUT_COLOURS = ["black", "#d62728", "#1f77b4", "#2ca02c", "#9467bd", "#8c564b"]
CONTROLS_WIDTH = 340


class Page:
    """The layout of one :class:`~optdesign.explorer.session.Session`; ``front``: the rows
    of a finished front (:func:`optdesign.explorer.front.front_points`) and its file.
    ``.layout`` is the Panel object a server serves and a notebook displays; ``wide``
    False puts the plots one under another (a notebook's cell is narrower than a page)."""

    def __init__(self, session, front=None, wide: bool = True):
        import panel as pn

        self.pn = pn
        self.session = session
        self.front = front
        self.wide = wide
        self._syncing = False
        self.shot = None
        self._build_widgets()
        self._build_plots()
        self.layout = self._arrange()
        self.refresh()

    # ----------------------------------------------------------------- widgets
    def _build_widgets(self) -> None:
        from optdesign.explorer.widgets import PromptDiscreteSlider, PromptSlider, TextPane

        pn, s = self.pn, self.session
        self.lengths = {}
        for name, lower, upper in s.lengths():
            step = _step(upper - lower)
            w = PromptSlider(
                **_label(f"{name} [mm]"), start=lower, end=upper, fixed_start=lower,
                fixed_end=upper, value=round(float(s.values[name]), 4), step=step,
                format=_shown(step), width=CONTROLS_WIDTH - 20,
                css_classes=[f"explore-length-{name}"])
            w.param.watch(lambda event, name=name: self._on_length(name, event.new), "value")
            self.lengths[name] = w
        key = s.problem.model.count_variable
        counts = s.counts()
        if len(counts) > 1:
            self.count = PromptDiscreteSlider(**_label(key), options=counts,
                                              value=int(s.values[key]),
                                              width=CONTROLS_WIDTH - 20,
                                              css_classes=["explore-count"])
            self.count.param.watch(lambda e: self._on_length(key, e.new), "value")
        else:
            self.count = pn.widgets.StaticText(**_label(key),
                                               value=f"{counts[0]} (fixed by the file)")
        self.eccentricity = PromptSlider(
            **_label("drawn at eccentricity e"), start=0.05, end=1.0, fixed_end=1.0,
            step=0.01, format=_shown(0.01), value=1.0, width=CONTROLS_WIDTH - 20,
            css_classes=["explore-eccentricity"])
        self.eccentricity.param.watch(lambda e: self._act(s.set_eccentricity, e.new),
                                      "value")
        self.bounds = {}
        for b in s.bounds():
            unit = "" if b.unit in ("", "-") else f" [{b.unit}]"
            w = PromptSlider(
                **_label(f"{b.label}{unit}"), start=b.lower, end=b.upper,
                value=float(b.value), step=b.step, format=_shown(b.step),
                width=CONTROLS_WIDTH - 20,
                css_classes=[f"explore-bound-{b.key.replace('.', '-')}"])
            w.param.watch(lambda event, key=b.key: self._on_bound(key, event.new), "value")
            self.bounds[b.key] = w
        primary = {"color" if "color" in pn.widgets.Button.param else "button_type": "primary"}
        self.reoptimise = pn.widgets.Button(**_label("re-optimise"), **primary,
                                            css_classes=["explore-reoptimise"])
        self.reoptimise.on_click(lambda _: self._reoptimise())
        self.follow = pn.widgets.Checkbox(**_label("follow: re-optimise when a bound moves"),
                                          css_classes=["explore-follow"])
        self.save_as = pn.widgets.TextInput(**_label("save the design as"),
                                            value="design.yaml", width=CONTROLS_WIDTH - 20,
                                            css_classes=["explore-save-as"])
        self.save = pn.widgets.Button(**_label("save"), css_classes=["explore-save"])
        self.save.on_click(lambda _: self._save())
        self.angle = pn.widgets.Player(**_label("crank angle (frame of one turn)"), start=0,
                                       end=FRAMES - 1, value=0, interval=80, loop_policy="loop",
                                       width=560, css_classes=["explore-player"])
        self.angle.param.watch(lambda e: self._draw_frame(), "value")
        self.headline = TextPane("", sizing_mode="stretch_width",
                                 css_classes=["explore-headline"])
        self.message = TextPane("", sizing_mode="stretch_width",
                                css_classes=["explore-message"])
        self.table = TextPane("", width=560, css_classes=["explore-table"])
        self.binding = TextPane("", sizing_mode="stretch_width",
                                css_classes=["explore-binding"])

    # ----------------------------------------------------------------- plots
    def _build_plots(self) -> None:
        from bokeh.core.properties import field
        from bokeh.models import ColumnDataSource, Legend, LegendItem, Range1d, Span
        from bokeh.plotting import figure

        self.links = ColumnDataSource(dict(x0=[], y0=[], x1=[], y1=[], colour=[], width=[]),
                                      name="explore-links")
        self.joints = ColumnDataSource(dict(x=[], y=[], name=[]), name="explore-joints")
        # every joint's path in one line, the paths apart by a NaN: two arrays to send
        self.paths = ColumnDataSource(dict(x=[], y=[]), name="explore-paths")
        # a square frame and equal spans: the drawing is to scale
        fig = figure(frame_width=430, frame_height=430, x_range=Range1d(-1, 1),
                     y_range=Range1d(-1, 1), title="the linkage to scale [mm]",
                     tools="pan,wheel_zoom,reset", name="explore-linkage")
        fig.line("x", "y", source=self.paths, color="#bbbbbb", line_width=1)
        fig.segment("x0", "y0", "x1", "y1", source=self.links, color="colour",
                    line_width="width")
        fig.scatter("x", "y", source=self.joints, size=6, color="white", line_color="black")
        fig.xaxis.axis_label, fig.yaxis.axis_label = "x [mm]", "y [mm]"
        self.linkage_figure = fig

        self.members = ColumnDataSource(dict(xs=[], ys=[], colour=[]), name="explore-members")
        self.outputs = ColumnDataSource(dict(xs=[], ys=[], colour=[], label=[]),
                                        name="explore-outputs")
        sp = figure(width=560, height=340, title="driving speed of each rocker, and the "
                    "output speed at each listed e", tools="pan,wheel_zoom,reset,hover",
                    tooltips=[("", "@label")], x_range=(0, 360), y_range=Range1d(-1, 1),
                    name="explore-speeds")         # y: the curves' span, set on each redraw
        sp.multi_line("xs", "ys", source=self.members, color="colour", line_width=1,
                      alpha=0.7)
        outputs = sp.multi_line("xs", "ys", source=self.outputs, color="colour",
                                line_width=2.5)
        sp.add_layout(Legend(items=[LegendItem(label=field("label"), renderers=[outputs])],
                             label_text_font_size="8pt", border_line_alpha=0.0),
                      "below")                  # under the plot: no curve hidden
        self.cursor = Span(location=0, dimension="height", line_color="#444444",
                           line_dash="dashed")
        sp.add_layout(self.cursor)
        sp.xaxis.axis_label = "crank angle φ1 [deg]"
        sp.yaxis.axis_label = f"speed in the {self.session.problem.stroke} direction [rad/s]"
        self.speeds_figure = sp
        self.front_figure = self._front_figure() if self.front is not None else None

    def _front_figure(self):
        from bokeh.models import ColumnDataSource, TapTool
        from bokeh.plotting import figure

        rows = self.front.rows
        self.front_source = ColumnDataSource(dict(
            x=[r["x"] for r in rows], y=[r["delta"] for r in rows],
            point=[r["point"] for r in rows],
            colour=[MEMBER_COLOURS[int(r["count"]) % len(MEMBER_COLOURS)] for r in rows],
            label=[f"point {r['point']}: {r['count_key']} = {r['count']}" for r in rows]),
            name="explore-front")
        fig = figure(width=560, height=300, tools="tap,pan,wheel_zoom,reset,hover",
                     tooltips=[("", "@label"), ("δ", "@y{0.0000}"), ("", "@x{0.0000}")],
                     title="the front: click a point to load its design",
                     name="explore-front-plot")
        fig.scatter("x", "y", source=self.front_source, size=9, color="colour")
        fig.xaxis.axis_label, fig.yaxis.axis_label = self.front.axis, "δ"
        fig.select_one(TapTool).mode = "replace"
        self.front_source.selected.on_change("indices", self._on_front_point)
        return fig

    def _arrange(self):
        pn = self.pn
        s = self.session
        controls = [pn.pane.HTML(f"<b>{html.escape(s.problem.name)}</b> "
                                 f"({html.escape(s.problem.mechanism)}, "
                                 f"{html.escape(s.problem.stroke)} stroke)"),
                    pn.pane.HTML("<b>free lengths</b>"), *self.lengths.values(), self.count,
                    self.eccentricity, pn.pane.HTML("<b>bounds</b>"), *self.bounds.values(),
                    self.reoptimise, self.follow, self.save_as, self.save]
        left = pn.Column(*controls, width=CONTROLS_WIDTH)
        front = [pn.pane.Bokeh(self.front_figure)] if self.front_figure is not None else []
        drawing = pn.Column(pn.pane.Bokeh(self.linkage_figure), self.angle)
        speeds = pn.Column(pn.pane.Bokeh(self.speeds_figure), self.binding)
        if self.wide:
            right = [self.headline, self.message, pn.Row(drawing, speeds),
                     pn.Row(self.table, *front)]
        else:
            right = [self.headline, self.message, drawing, speeds, self.table, *front]
        from optdesign.explorer.inline import InlineRow

        return InlineRow(left, pn.Column(*right), css_classes=["explore-page"])

    # ----------------------------------------------------------------- actions
    def _act(self, action, *args) -> bool:
        """Run one of the session's actions and refresh the page; a fault the user can
        fix (a value refused, a file that does not load) is one line in the page."""
        if self._syncing:
            return False
        try:
            action(*args)
        except (OptDesignError, ValueError, OSError) as exc:
            self._say(str(exc), error=True)
            self._sync()                # the controls back to the session's state
            return False
        except Exception as exc:        # a bug: one line in the page, and the page goes on
            self._say(_internal(exc), error=True)
            self._sync()
            return False
        self.refresh()
        return True

    def _on_length(self, name: str, value) -> None:
        self._act(self.session.set, name, value)

    def _on_bound(self, key: str, value) -> None:
        if self._act(self.session.set_bound, key, value) and self.follow.value:
            self._reoptimise()

    def _reoptimise(self) -> None:
        if self.shot is not None and self.shot.analysis is None:
            self._say("re-optimise starts from a design that can be evaluated: move the "
                      "lengths first", error=True)
            return
        try:
            done = self.session.reoptimise()
        except OptDesignError as exc:
            self._say(str(exc), error=True)
            return
        except Exception as exc:        # a bug: one line in the page, and the page goes on
            self._say(_internal(exc), error=True)
            return
        self._sync()
        self.refresh(keep_message=True)
        self._say(done.line, error=done.status != "optimal")
        self.binding.object = f"<span class='explore-binding-text'>" \
                              f"{html.escape(done.binding)}</span>" if done.binding else ""

    def _save(self) -> None:
        try:
            path = self.session.save(Path(self.save_as.value).expanduser())
        except (OptDesignError, OSError, ValueError) as exc:
            self._say(f"save: {exc}", error=True)
            return
        self._say(f"saved {path} (optdesign analyze PROBLEM --design {path.name} reads it)")

    def _on_front_point(self, attr, old, new) -> None:
        if not new:
            return
        point = int(self.front_source.data["point"][new[0]])
        try:
            source = self.session.load(self.front.path, point)
        except OptDesignError as exc:
            self._say(str(exc), error=True)
            return
        self._sync()
        self.refresh()
        self._say(f"loaded {source}")

    # ----------------------------------------------------------------- drawing
    def _sync(self) -> None:
        """The controls set to the session's state, without acting on the change."""
        self._syncing = True
        try:
            for name, w in self.lengths.items():      # shown to 4 decimals, kept exact
                shown = round(float(self.session.values[name]), 4)
                if w.value != shown:
                    w.value = shown
            key = self.session.problem.model.count_variable
            if hasattr(self.count, "options") and self.count.value != self.session.values[key]:
                self.count.value = int(self.session.values[key])
            for b in self.session.bounds():
                w = self.bounds.get(b.key)
                if w is not None and w.value != b.value:
                    w.value = float(b.value)
        finally:
            self._syncing = False

    def _say(self, text: str, error: bool = False) -> None:
        colour = "#b00020" if error else "#1b5e20"
        self.message.object = (f"<div class='explore-message-text' style='color:{colour}'>"
                               f"{html.escape(text)}</div>") if text else ""

    def refresh(self, keep_message: bool = False) -> None:
        """Evaluate the design on screen and redraw every figure of it (the page's changes
        sent to the browser at once, in one message)."""
        from panel.io import hold

        with hold():
            self._redraw(keep_message)

    def _redraw(self, keep_message: bool) -> None:
        shot = self.session.evaluate()
        self.shot = shot
        self.headline.object = _headline(shot)
        self.table.object = _table(shot)
        if not keep_message:
            self._say(shot.message, error=True) if shot.message else self._say("")
            self.binding.object = ""
        if shot.turn is None:
            for source in (self.links, self.joints, self.paths, self.members, self.outputs):
                source.data = {k: [] for k in source.data}
            return
        t = shot.turn
        # the crank angles and the speeds as lists, in the message's text (the angles only
        # when the number of curves changes); the joints' paths as two arrays, sent as
        # binary (every array is two frames more of the message, each a task of the page's)
        deg = np.append(t.phi_deg, 360.0).tolist()
        _columns(self.members, xs=[deg] * len(t.speeds),
                 ys=[_drawn(np.append(v, v[0])) for v in t.speeds],
                 colour=[MEMBER_COLOURS[k % len(MEMBER_COLOURS)] for k in range(len(t.speeds))])
        shown = t.outputs or (("output", t.output),)
        _columns(self.outputs, xs=[deg] * len(shown),
                 ys=[_drawn(np.append(v, v[0])) for _, v in shown],
                 colour=[OUTPUT_COLOURS[i % len(OUTPUT_COLOURS)] for i in range(len(shown))],
                 label=[label for label, _ in shown])
        # the speeds' span set here, as the page would fit it (5 % margins), so the page
        # neither fits it nor sends the fitted span back
        curves = np.concatenate([t.speeds.ravel(), *(v for _, v in shown)])
        low, high = float(np.nanmin(curves)), float(np.nanmax(curves))
        _span(self.speeds_figure.y_range, low, high, 0.05 * (high - low) or 1.0)
        joints = t.positions.reshape(-1, 2)
        gap = np.full((1, len(t.names), 2), np.nan)             # (frames + 1, joints, 2)
        paths = np.concatenate([t.positions, gap]).transpose(1, 0, 2).reshape(-1, 2)
        paths = paths.astype(np.float32)        # to 1e-7 of the span: far below a pixel
        _columns(self.paths, x=paths[:, 0], y=paths[:, 1])
        lo, hi = np.nanmin(joints, axis=0), np.nanmax(joints, axis=0)
        half = 0.55 * max(hi - lo) or 1.0
        centre = (lo + hi) / 2
        fig = self.linkage_figure
        _span(fig.x_range, centre[0], centre[0], half)
        _span(fig.y_range, centre[1], centre[1], half)
        self._draw_frame()

    def _draw_frame(self) -> None:
        """The linkage at the player's crank angle."""
        t = self.shot.turn if self.shot is not None else None
        if t is None:
            return
        frame = int(self.angle.value) % len(t.phi_deg)
        at = t.positions[frame]
        index = {n: i for i, n in enumerate(t.names)}
        a = [at[index[link[0]]] for link in t.links]
        b = [at[index[link[1]]] for link in t.links]
        a, b = np.array(a), np.array(b)
        # a few numbers each: lists, in the message's text
        _columns(self.links, x0=a[:, 0].tolist(), y0=a[:, 1].tolist(), x1=b[:, 0].tolist(),
                 y1=b[:, 1].tolist(), colour=[ROLE_COLOURS[link[2]] for link in t.links],
                 width=[ROLE_WIDTHS[link[2]] for link in t.links])
        _columns(self.joints, x=at[:, 0].tolist(), y=at[:, 1].tolist(), name=list(t.names))
        self.cursor.location = float(t.phi_deg[frame])


def _internal(exc: Exception) -> str:
    """The page's line for a fault that is a bug, as the command line words it."""
    return (f"internal error ({type(exc).__name__}: {str(exc)[:200]}); please report it with "
            f"the problem file")


def _columns(source, **columns) -> None:
    """Put ``columns`` in the ColumnDataSource ``source``, sending the page only those that
    changed (a move changes the curves, not the crank angles, colours or names); all of them
    when the number of rows changes."""
    old = source.data
    rows = {len(v) for v in columns.values()}
    if set(old) != set(columns) or rows != {len(v) for v in old.values()}:
        source.data = columns
        return
    changed = {k: v for k, v in columns.items() if not _same(old[k], v)}
    if changed:
        source.data.update(changed)


def _same(old, new) -> bool:
    """Whether two columns hold the same values (NaN equal to NaN)."""
    if isinstance(old, np.ndarray) or isinstance(new, np.ndarray):
        old, new = np.asarray(old), np.asarray(new)
        return old.shape == new.shape and old.dtype == new.dtype and bool(
            np.array_equal(old, new, equal_nan=old.dtype.kind == "f"))
    if len(old) != len(new):
        return False
    return all(_same(a, b) if isinstance(a, (np.ndarray, list)) or isinstance(b, np.ndarray)
               else a == b for a, b in zip(old, new))


def _drawn(curve: np.ndarray) -> list:
    """A speed curve as the page draws it: a list in the message's text (an array is two
    frames more of the message, each a task of the page's), to six significant digits of
    its largest value (a few millionths of the plot's height)."""
    finite = curve[np.isfinite(curve)]
    scale = float(np.max(np.abs(finite))) if finite.size else 0.0
    decimals = 5 - math.floor(math.log10(scale)) if scale > 0 else 6
    return np.round(curve, decimals).tolist()


def _span(axis, low: float, high: float, margin: float) -> None:
    """Show [low - margin, high + margin] on the Range1d ``axis``, and go back to it on the
    plot's reset."""
    axis.start = axis.reset_start = float(low - margin)
    axis.end = axis.reset_end = float(high + margin)


def _step(span: float) -> float:
    """A length slider's step: about a thousandth of its range, rounded to 1, 2 or 5."""
    raw = span / 1000 if span > 0 else 0.001
    exponent = math.floor(math.log10(raw))
    return next(m for m in (1, 2, 5, 10) if m >= raw / 10 ** exponent) * 10 ** exponent


def _headline(shot) -> str:
    """δ named, the ratio and the least transmission angle, in one line."""
    if shot.analysis is None or not shot.analysis.assembles:
        return "<div class='explore-headline-text'><b>does not assemble</b></div>"
    a = shot.analysis
    ratio = shot.ratio
    ratio_text = f"ratio = {ratio:.6f}" if ratio is not None else ""
    return (f"<div class='explore-headline-text' style='font-size:1.15em'>"
            f"<b class='explore-delta'>{html.escape(shot.delta_text)}</b>; "
            f"<span class='explore-ratio'>{ratio_text}</span>; least transmission angle "
            f"<span class='explore-angle'>{a.min_transmission_angle_deg:.2f}°</span></div>")


def _table(shot) -> str:
    """Every figure of the design, constraints' margins red where violated."""
    rows = shot.rows()
    if not rows:
        return ""
    red = " class='explore-violated' style='color:#b00020;font-weight:bold'"
    body = "".join(
        f"<tr{red if r.violated else ''}><td>{html.escape(r.name)}</td>"
        f"<td style='text-align:right'>{html.escape(r.value)}</td></tr>" for r in rows)
    return (f"<table class='explore-figures' style='border-collapse:collapse;width:100%'>"
            f"<tr><th style='text-align:left'>figure (exact)</th><th style='text-align:right'>"
            f"value</th></tr>{body}</table>")


def _label(text: str) -> dict:
    """A widget's caption as a keyword: ``label`` where Panel has it (``name`` is deprecated
    for it from Panel 1.9, as a button's ``button_type`` is for ``color``), ``name``
    before."""
    from panel.widgets import Widget

    return {"label" if "label" in Widget.param else "name": text}


def _shown(step: float) -> str:
    """The number field's format beside a slider of ``step``: the step's decimals, then up
    to four where a value lies between steps (one re-optimised or typed), so a value the
    browser's arithmetic leaves at 57.00000000000001 reads 57.0; the value itself is kept
    exact."""
    decimals = max(0, -math.floor(math.log10(step) + 1e-9))
    optional = max(0, 4 - decimals)
    if decimals == 0:
        return "0[.][" + "0" * optional + "]"
    return "0." + "0" * decimals + (f"[{'0' * optional}]" if optional else "")

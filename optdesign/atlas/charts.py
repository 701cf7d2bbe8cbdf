"""The atlas's figures: the least δ against the phase count for each rule
(``atlas_counts.png``), and δ over two axes as a heat map with the infeasible cells shaded
(``atlas_map.png``); one panel per value of the remaining axes. Each takes a computed atlas,
returns the figure and imports matplotlib on first use."""
from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np

from optdesign.figures.design import pyplot
from optdesign.outputs.atomic import atomic_savefig

#: axes' labels on the figures
LABELS = {"phases": "phase count n", "min_transmission_angle_deg": "least transmission angle "
          "rule μ_min [deg]", "min_pin_radius": "least pin radius / l1",
          "min_ratio": "ratio floor", "stroke": "stroke"}
SHORT = {"phases": "n", "min_transmission_angle_deg": "μ_min", "min_pin_radius": "pin/l1",
         "min_ratio": "ratio ≥", "stroke": "stroke"}
#: most panels drawn (the first ones of the remaining axes' values)
MAX_PANELS = 12


def layout(spec) -> tuple[str, str | None, list[str]]:
    """(the x axis, the axis of the lines or the map's rows, the axes of the panels)."""
    names = list(spec.axes)
    x = "phases" if "phases" in names else names[0]
    rest = [n for n in names if n != x]
    y = "min_transmission_angle_deg" if "min_transmission_angle_deg" in rest else \
        (rest[0] if rest else None)
    return x, y, [n for n in rest if n != y]


def panels(result) -> list[tuple[dict, list[dict]]]:
    """(the panel's values of the remaining axes, its records), at most MAX_PANELS."""
    spec = result.spec
    _, _, rest = layout(spec)
    out = []
    for combo in itertools.product(*(spec.axes[n] for n in rest)):
        where = dict(zip(rest, combo))
        recs = [r for r in result.records
                if all(r["values"][n] == v for n, v in where.items())]
        out.append((where, recs))
    return out[:MAX_PANELS]


def panel_title(where: dict) -> str:
    return ", ".join(f"{SHORT[n]} {v:g}" if isinstance(v, (int, float)) else f"{SHORT[n]} {v}"
                     for n, v in where.items()) or "every cell"


def _grid(n: int):
    plt = pyplot()
    cols = min(n, 3)
    rows = -(-n // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.6 * cols, 3.8 * rows), squeeze=False,
                             sharey=True)
    for ax in axes.flat[n:]:
        ax.set_visible(False)
    return fig, axes.flat


def plot_counts(result):
    """The least δ against the x axis (the phase count), one line per value of the y axis
    (the transmission-angle rule); an infeasible cell leaves a gap, marked × on the axis."""
    spec = result.spec
    x, y, _ = layout(spec)
    groups = panels(result)
    fig, axes = _grid(len(groups))
    cmap = pyplot().get_cmap("viridis")
    lines = spec.axes[y] if y else [None]
    for ax, (where, recs) in zip(axes, groups):
        for k, value in enumerate(lines):
            mine = [r for r in recs if y is None or r["values"][y] == value]
            xs = np.array([r["values"][x] for r in mine], dtype=float)
            ds = np.array([r["delta"] if r["feasible"] else np.nan for r in mine], dtype=float)
            colour = cmap(k / max(1, len(lines) - 1))
            label = None if y is None else f"{SHORT[y]} {value:g}"
            ax.plot(xs, ds, "o-", color=colour, label=label, ms=4)
            bad = np.isnan(ds)
            if bad.any():          # on the x axis, below the log scale's data
                ax.plot(xs[bad], np.full(bad.sum(), 0.0), "x", color=colour, ms=7,
                        clip_on=False, transform=ax.get_xaxis_transform())
        ax.set_title(panel_title(where), fontsize=10)
        ax.set_xlabel(LABELS[x])
        ax.grid(alpha=0.3)
        ax.set_yscale("log")
        ax.yaxis.set_major_formatter(pyplot().FuncFormatter(lambda v, _: f"{v:g}"))
        ax.yaxis.set_minor_formatter(pyplot().FuncFormatter(
            lambda v, _: f"{v:g}" if str(round(v, 6))[-1] in "2345" else ""))
        if x == "phases":
            ax.set_xticks(spec.axes[x])
    axes[0].set_ylabel("least ripple δ")
    if y is not None:
        axes[0].legend(fontsize=8, title="rule (× infeasible)", title_fontsize=8)
    fig.suptitle(f"{spec.name}: least δ against {LABELS[x]}", fontsize=11)
    fig.tight_layout()
    return fig


def plot_map(result):
    """δ over the x and y axes as a heat map, one panel per value of the other axes; an
    infeasible cell is hatched grey and names its binding rule's first letters."""
    spec = result.spec
    x, y, _ = layout(spec)
    groups = panels(result)
    xs, ys = list(spec.axes[x]), list(spec.axes[y]) if y else [None]
    feasible = [r["delta"] for r in result.records if r["feasible"]]
    lo, hi = (min(feasible), max(feasible)) if feasible else (0.0, 1.0)
    fig, axes = _grid(len(groups))
    plt = pyplot()
    from matplotlib.colors import LogNorm
    for ax, (where, recs) in zip(axes, groups):
        grid = np.full((len(ys), len(xs)), np.nan)
        for r in recs:
            i = ys.index(r["values"][y]) if y else 0
            grid[i, xs.index(r["values"][x])] = r["delta"] if r["feasible"] else np.nan
        ax.add_patch(plt.Rectangle((-0.5, -0.5), len(xs), len(ys), facecolor="0.85",
                                   hatch="///", edgecolor="0.6", lw=0, zorder=0))
        image = ax.imshow(grid, origin="lower", aspect="auto", cmap="viridis_r",
                          norm=LogNorm(lo, hi), extent=(-0.5, len(xs) - 0.5, -0.5, len(ys) - 0.5),
                          zorder=1)
        if len(xs) * len(ys) <= 120:
            for i, j in itertools.product(range(len(ys)), range(len(xs))):
                if np.isfinite(grid[i, j]):
                    shade = np.log(grid[i, j] / lo) / np.log(hi / lo) if hi > lo else 0
                    ax.text(j, i, f"{grid[i, j]:.3f}"[1:], ha="center", va="center",
                            fontsize=7, color="white" if shade > 0.55 else "black", zorder=2)
        ax.set_xticks(range(len(xs)), [f"{v:g}" if not isinstance(v, str) else v for v in xs])
        ax.set_yticks(range(len(ys)), [("" if v is None else f"{v:g}"
                                        if not isinstance(v, str) else v) for v in ys])
        ax.set_xlabel(LABELS[x])
        ax.set_title(panel_title(where), fontsize=10)
    if y is not None:
        axes[0].set_ylabel(LABELS[y])
    fig.colorbar(image, ax=list(axes[:len(groups)]), label="least ripple δ, log scale "
                                                            "(hatched: infeasible)", shrink=0.9)
    fig.suptitle(f"{spec.name}: least δ over {SHORT[x]} and {SHORT.get(y, '')}", fontsize=11)
    return fig


def chart_jobs(result, out) -> list[tuple]:
    """atlas_counts.png and atlas_map.png in ``out`` as jobs, ``(function, args)`` each, for a
    :class:`~optdesign.outputs.figure_process.FigureProcess` to draw beside the command."""
    out = Path(out)
    return [(saved_chart, (plot, result, out / name))
            for name, plot in (("atlas_counts.png", plot_counts), ("atlas_map.png", plot_map))]


def saved_chart(plot, result, path: Path) -> Path:
    """``plot(result)`` saved atomically to ``path``, the figure closed whatever happens."""
    fig = plot(result)
    try:
        return atomic_savefig(fig, path, dpi=110)
    finally:
        pyplot().close(fig)


def write_charts(result, out) -> list[Path]:
    """atlas_counts.png and atlas_map.png in ``out``, each atomically, drawn here."""
    return [function(*args) for function, args in chart_jobs(result, out)]

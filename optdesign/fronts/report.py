"""The report of a sweep: fronts of every phase count, the knee design's drawing and speed
curves, the non-dominated designs, the indicators and how the run was made.

Written as ``report.md`` (images beside it as PNG) and ``report.html`` (self-contained: the
same PNGs embedded as base64). Both are rendered from one list of blocks, so they agree.
"""
from __future__ import annotations

import base64
import html
import platform
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from optdesign.figures.design import pyplot
from optdesign.fronts.axis import Axis
from optdesign.fronts.indicators import REFERENCE
from optdesign.fronts.refine import LOCAL, MAX_ROUNDS, VERIFIED

MARKERS = "osD^v<>p*h"


def plot_fronts(points, ax=None, title: str | None = None, axis: Axis = Axis()):
    """δ against ratio (or the quantity ``axis`` names): each phase count's own front (line),
    the points it dominates (faint), the overall non-dominated designs (ringed) and the knee
    (star)."""
    plt = pyplot()
    x = axis.name
    fig, ax = (ax.figure, ax) if ax is not None else plt.subplots(figsize=(7.5, 5))
    ok = points[points["status"].isin(VERIFIED)]
    for j, (n, g) in enumerate(ok.groupby("count")):
        front = g[g["count_front"]].sort_values(x)
        line, = ax.plot(front[x], front["delta"], marker=MARKERS[j % len(MARKERS)],
                        ms=5, lw=1.4, label=f"n = {n} ({len(front)} points)")
        rest = g[~g["count_front"]]
        if len(rest):
            ax.plot(rest[x], rest["delta"], MARKERS[j % len(MARKERS)], ms=4, alpha=0.3,
                    color=line.get_color())
    if "round" in ok:
        refined = ok[ok["round"].fillna(0) >= 1]
        if len(refined):
            ax.plot(refined[x], refined["delta"], "+", ms=6, color="black", mew=0.8,
                    label="refined ε (after the uniform pass)")
    nd = ok[ok["non_dominated"]]
    ax.plot(nd[x], nd["delta"], "o", ms=10, mfc="none", mec="black", mew=1.0,
            label="non-dominated over every n")
    local = ok[ok["status"] == LOCAL]
    if len(local):
        ax.plot(local[x], local["delta"], "x", ms=9, color="darkorange", mew=2.0, zorder=6,
                label="local: a known design beats it on its own ε")
    if "knee" in points.attrs and points.attrs["knee"] is not None:
        k = points.loc[points.attrs["knee"]]
        ax.plot(k[x], k["delta"], "*", ms=16, color="crimson", mec="black",
                label=f"knee (n = {int(k['count'])})")
    ax.set_xlabel(axis_label(axis))
    ax.set_ylabel("ripple δ (exact)")
    ax.set_title(title or f"ripple against {axis.name}, per phase count")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return fig


def axis_label(axis: Axis) -> str:
    """The x label of a front's figures."""
    if axis.is_ratio:
        return "ratio = mean output speed / ω1 (at e = 1; gear ratio i = 1/ratio)"
    return f"{axis.name}: {axis.label} (worst over the listed eccentricities)"


def plot_lengths(points, bounds: dict, axes=None, title: str | None = None,
                 axis: Axis = Axis()):
    """Each free length of every phase count's front against the ratio, one panel per
    length, with the length's lower and upper bounds as dashed lines (a front running along
    one is held by that bound). ``bounds``: {length: (lower, upper)} in mm."""
    from matplotlib.ticker import MaxNLocator

    plt = pyplot()
    names = list(bounds)
    if axes is None:
        ncols = min(3, max(len(names), 1))
        nrows = -(-len(names) // ncols)
        fig, axes = plt.subplots(nrows, ncols, figsize=(4.3 * ncols, 3.3 * nrows + 0.6),
                                 sharex=True, squeeze=False)
        for ax in axes.ravel()[len(names):]:
            ax.set_visible(False)
    axes = list(np.atleast_1d(axes).ravel())
    fig = axes[0].figure
    ok = points[points["status"].isin(VERIFIED)]
    knee = points.attrs.get("knee")
    for ax, name in zip(axes, names):
        for j, (n, g) in enumerate(ok.groupby("count")):
            front = g[g["count_front"]].sort_values(axis.name)
            ax.plot(front[axis.name], front[name], marker=MARKERS[j % len(MARKERS)], ms=4.5,
                    lw=1.3, label=f"n = {n}")
        if knee is not None:
            k = points.loc[knee]
            ax.plot(k[axis.name], k[name], "*", ms=13, color="crimson", mec="black", zorder=5,
                    label="knee")
        lower, upper = bounds[name]
        for value, side in ((lower, "lower"), (upper, "upper")):
            ax.axhline(value, color="0.3", ls="--", lw=1.0)
            ax.annotate(f"{side} {value:g}", (1.0, value), xycoords=("axes fraction", "data"),
                        xytext=(-3, 2 if side == "lower" else -2), textcoords="offset points",
                        ha="right", va="bottom" if side == "lower" else "top", fontsize=7.5,
                        color="0.3")
        pad = 0.06 * (upper - lower)
        ax.set_ylim(lower - pad, upper + pad)
        ax.set_title(name, fontsize=10)
        ax.set_ylabel(f"{name} [mm]")
        ax.set_xlabel("ratio = output / input speed (at e = 1)" if axis.is_ratio
                      else f"{axis.name} [{axis.unit}]")
        ax.tick_params(axis="x", labelbottom=True)
        ax.xaxis.set_major_locator(MaxNLocator(5))
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7.5, loc="best")
    fig.suptitle(title or "free lengths along the front", fontsize=11)
    fig.tight_layout()
    return fig


def run_info(problem, result, problem_path=None, command: str | None = None) -> dict:
    """Problem file, versions, seeds and times: enough to make the run again."""
    import casadi
    import numpy
    import pandas

    from importlib.metadata import version
    return {"problem_file": str(problem_path or problem.source),
            "problem": problem.name, "mechanism": problem.mechanism, "stroke": problem.stroke,
            "optdesign": version("optdesign"), "casadi": casadi.__version__, "numpy": numpy.__version__,
            "pandas": pandas.__version__, "python": platform.python_version(),
            "platform": platform.platform(),
            "seed": problem.solver.seed, "starts": problem.solver.starts,
            "samples": problem.solver.samples, "points_per_count": result.run.get("points"),
            "counts": result.run.get("counts"), "workers": result.run.get("workers"),
            "wall_time_s": round(result.run.get("wall_time_s", float("nan")), 2),
            "resumed_points": result.run.get("resumed_points", 0),
            "finished_utc": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M:%S UTC"),
            "command": command or ""}


def _unit(text: str) -> str:
    """A unit without its explanation: ``"mm (l2 - l2_prime)"`` reads ``mm``."""
    return text.split(" (")[0]


def _fmt(v, digits=4):
    if v is None or v != v:
        return "n/a"
    if isinstance(v, float):
        return f"{v:.{digits}f}"
    return str(v)


def blocks(result, problem, info: dict, images: dict) -> list[tuple]:
    lengths = list(problem.model.lengths)
    ind = result.indicators
    axis = result.axis
    x = axis.name
    side = "≥" if axis.sign > 0 else "≤"
    out = [("h1", f"Pareto front: {problem.name}"),
           ("p", f"{problem.mechanism}, {problem.stroke} stroke, ω1 = {problem.input_speed:g} "
                 f"rad/s. Least ripple δ ({problem.objective.ripple}) subject to {x} {side} ε"
                 + ("" if axis.is_ratio else f" ({axis.label})") +
                 f", ε swept across each phase count's reachable {x} range; every point "
                 f"re-evaluated by the exact evaluator.")]
    out.append(("h2", "Fronts"))
    out.append(("img", "fronts.png", images.get("fronts.png")))
    pts = result.points
    if "round" in pts and (pts["round"].fillna(0) >= 1).any():
        later = pts[pts["round"].fillna(0) >= 1]
        again = int((later["start_from"] == "dominating").sum())
        area = int((later["round"] > MAX_ROUNDS).sum())
        out.append(("p", f"{len(later) - again - area} point(s) (+ in the figure) were added "
                         f"after the uniform ε pass where a count's front was coarse or turned"
                         + (f", {area} more where the front of every count together left the "
                            f"largest area of the hypervolume uncovered" if area else "")
                         + (f", and {again} dominated point(s) re-solved from the design "
                            f"dominating them" if again else "")
                         + f"; {int(pts['merged'].fillna(0).sum())} ε point(s) that reached a "
                           f"design already listed are merged into its row."))
    stretches = jumps(result)
    if stretches:
        out.append(("h2", "Where the front jumps"))
        out.append(("p", f"Stretches of the overall front longer than a tenth of its {x} span "
                         f"with no design inside: the ε values solved there (if any) reached "
                         f"designs outside the stretch, so the front jumps across it."))
        out.append(("table", [f"from {x}", f"to {x}", "δ from", "δ to", "why"], stretches))
    if images.get("lengths.png") is not None:
        out.append(("h2", "Lengths along the front"))
        out.append(("p", f"Each free length of every phase count's front against the {x} it "
                         "reaches, between its bounds from the problem file (dashed): a front "
                         "that runs along a bound is held there by it."))
        out.append(("img", "lengths.png", images["lengths.png"]))
    out.append(("h2", "Indicators"))
    out.append(("p", f"Objectives δ (minimised) and {x} ({'max' if axis.sign > 0 else 'min'}"
                     "imised), normalised so the ideal "
                     "point is (0, 0) and the nadir (1, 1) of the front judged; hypervolume "
                     f"to the reference point {REFERENCE} in that space (at most "
                     f"{REFERENCE[0] * REFERENCE[1]:.2f}); spacing is Schott's (0 for evenly "
                     f"spaced points); the knee is the design of the most {x} per unit of "
                     f"ripple, on the values' own scales (below)."))
    rows = [["every n", ind["n_points"], _fmt(ind["hypervolume"]), _fmt(ind["spacing"]),
             _nadir(ind, x)]]
    for n, v in result.per_count.items():
        rows.append([f"n = {n}", v["n_points"], _fmt(v["hypervolume"]), _fmt(v["spacing"]),
                     _nadir(v, x)])
    out.append(("table", ["front", "non-dominated points", "hypervolume", "spacing",
                          f"ideal / nadir (δ, {x})"], rows))
    if ind["n_points"] == 1:
        out.append(("p", f"One design only: no trade-off between δ and the {x} in these "
                         "bounds, and no hypervolume to report."))
    best = "largest" if axis.sign > 0 else "least"
    limits = [(e["count"], axis.value_of(e), e.get("ratio_limited_by", ""))
              for e in result.ends if e.get("kind") == axis.end and e.get("status") == "optimal"]
    if limits:
        out.append(("h2", f"What limits the {x}"))
        out.append(("p", f"At each phase count's {best}-{x} end, the constraints and bounds "
                         "that bind (IPOPT's active set): relaxing one of them is what would "
                         f"reach a {'larger' if axis.sign > 0 else 'smaller'} {x}."))
        out.append(("table", ["n", f"{best} {x}", "limited by"],
                    [[n, _fmt(r, 5), by or "nothing active (an interior maximum)"]
                     for n, r, by in limits]))
    knee = result.knee
    if knee is not None:
        out.append(("h2", "The knee design (best compromise)"))
        out.append(("p", knee_reason(result)))
        out.append(("p", f"n = {int(knee['count'])}: " + ", ".join(
            f"{k} = {knee[k]:.3f} mm" for k in lengths) +
            f"; δ = {knee['delta']:.5f}, ratio = {knee['ratio']:.5f}"
            + ("" if axis.is_ratio else f", {x} = {knee[x]:.5g} {axis.unit}") +
            ", least transmission "
            f"angle {knee['min_transmission_angle_deg']:.2f}°" +
            "".join(f", {c.replace('_', ' ')} {knee[c]:.2f} {_unit(u)}"
                    for c, u in result.criteria_columns.items()
                    if knee.get(c) == knee.get(c) and knee.get(c) is not None) +
            (f", local slope dδ/d ratio = {knee['ratio_multiplier']:.4g}"
             if knee.get("ratio_multiplier") == knee.get("ratio_multiplier") and
             knee.get("ratio_multiplier") is not None else "") + "."))
        out.append(("img", "knee_mechanism.png", images.get("knee_mechanism.png")))
        out.append(("img", "knee_speeds.png", images.get("knee_speeds.png")))
        if images.get("knee_animation.html") is not None:
            out.append(("link", "knee_animation.html",
                        "The knee design over one crank turn (an animation, its driving rocker "
                        "highlighted)"))
    out.append(("h2", "Non-dominated designs (over every phase count)"))
    extra = [] if axis.is_ratio else [x]
    own = list(result.criteria_columns)
    cols = ["count", "delta", "ratio"] + extra + lengths + [
        "min_transmission_angle_deg"] + own + ["ratio_multiplier", "binding", "status"]
    head = ["n", "δ", "ratio"] + [f"{x} [{axis.unit}]" for x in extra] + [
        f"{k} [mm]" for k in lengths] + ["μ_min [°]"] + [
        f"{c.replace('_', ' ')} [{_unit(result.criteria_columns[c])}]" for c in own] + [
        "dδ/d ratio", "binding", "status"]
    rows = [[_fmt(r[c], 5 if c in ("delta", "ratio") else 3) if c != "count" else
             int(r[c]) for c in cols] for _, r in result.front.iterrows()]
    out.append(("table", head, rows))
    local = result.points[result.points["status"] == LOCAL]
    if len(local):
        out.append(("p", f"{len(local)} point(s) are local (× in the figure): a verified "
                         f"design of their phase count meets their ε with less ripple, and a "
                         f"re-solve from it did not reach it; their status is local, not "
                         f"optimal, and the better design is on the front: "
                         + "; ".join(f"n = {int(r['count'])}, ε = {r['epsilon']:.5g}, δ = "
                                     f"{r['delta']:.5f}" for _, r in local.iterrows())))
    failed = result.points[~result.points["status"].isin(VERIFIED)]
    if len(failed):
        out.append(("p", f"{len(failed)} sweep point(s) reached no verified feasible design: "
                         + "; ".join(f"n = {int(r['count'])}, ε = {r['epsilon']:.4f}: "
                                     f"{r['status']}" for _, r in failed.iterrows())))
    out.append(("h2", "How the run was made"))
    out.append(("table", ["", ""], [[k, _fmt(v)] for k, v in info.items()]))
    return out


#: a stretch of the overall front longer than this share of its span is reported as a jump
JUMP_SHARE = 0.1


def jumps(result) -> list[list]:
    """The stretches of the overall front, longer than :data:`JUMP_SHARE` of its span in the
    quantity swept against, that no design fills, with why: a change of phase count, a bound
    or constraint that binds at one end and not at the other, else a second branch of
    designs (the lengths differ at the two ends)."""
    x = result.axis.name
    front = result.front
    if len(front) < 2:
        return []
    values = front[x].to_numpy(dtype=float)
    span = float(values.max() - values.min())
    rows = []
    for (_, a), (_, b) in zip(front.iloc[:-1].iterrows(), front.iloc[1:].iterrows()):
        if span <= 0 or abs(b[x] - a[x]) <= JUMP_SHARE * span:
            continue
        if a["count"] != b["count"]:
            why = f"the phase count changes (n = {int(a['count'])} to {int(b['count'])})"
        else:
            ba = {t.strip() for t in str(a.get("binding") or "").split(";") if t.strip()}
            bb = {t.strip() for t in str(b.get("binding") or "").split(";") if t.strip()}
            if ba != bb:
                names = sorted(ba ^ bb)
                why = "what binds changes: " + ", ".join(names)
            else:
                why = "a second branch of designs (the same constraints bind at both ends)"
        rows.append([f"{a[x]:.5g}", f"{b[x]:.5g}", f"{a['delta']:.5f}", f"{b['delta']:.5f}",
                     why])
    return rows


def knee_reason(result) -> str:
    """Why the knee is the design it is, on the spans a designer reads: a flat front (δ the
    same within its resolution) recommends its best end; otherwise the spans the knee was
    judged on."""
    ind, axis = result.indicators, result.axis
    ideal, nadir = ind.get("ideal") or {}, ind.get("nadir") or {}
    if not ideal:
        return "One design: it is the recommendation."
    x = axis.name
    lo, hi = sorted((ideal[x], nadir[x]))
    span = f"{x} {lo:.5g}–{hi:.5g}" + ("" if axis.unit == "-" else f" {axis.unit}")
    best = "largest" if axis.sign > 0 else "least"
    if ind.get("flat"):
        return (f"The front is flat: δ is the same within {result.resolution:g} (the δ "
                f"resolution) over {span}, so the knee is the end of the {best} {x}: take it, "
                f"it costs no ripple a designer can read.")
    d_lo, d_hi = ideal["delta"], nadir["delta"]
    relative = (f" (δ by {100 * (d_hi - d_lo) / d_lo:.3g} %, {x} by "
                f"{100 * (hi - lo) / abs(lo):.3g} %)" if d_lo > 0 and lo != 0 else "")
    text = f"The front spans δ {d_lo:.5f}–{d_hi:.5f} over {span}{relative}; "
    knee, end = result.knee, result.front.iloc[-1 if axis.sign > 0 else 0]
    if ind.get("knee_rule") == "per_ripple":
        per = "more" if axis.sign > 0 else "less"
        text += (f"the knee is the design of the most {x} per unit of ripple ({x}/δ largest)"
                 if axis.sign > 0 else
                 f"the knee is the design of the least {x} for its ripple ({x}·δ least)")
        start = result.front.iloc[0 if axis.sign > 0 else -1]
        if knee is not None and knee.name == end.name:
            text += (f", the {best}-{x} end: all along the front each per cent {per} {x} costs "
                     f"less than a per cent more ripple, so take it.")
        elif knee is not None and knee.name == start.name:
            text += (f", the least-ripple end: all along the front each per cent {per} {x} "
                     f"costs more than a per cent more ripple.")
        else:
            text += (f": towards it each per cent {per} {x} costs less than a per cent more "
                     f"ripple, past it more.")
    else:
        text += (f"the knee is the design farthest from the chord between its two ends, on "
                 f"both spans scaled to one (a {x} or a δ that is not positive has no per "
                 f"cent to trade).")
    resting = ind.get("knee_at_rest_excluded", 0)
    if resting:
        text += (f" {resting} design{'s' if resting > 1 else ''} of the front, "
                 f"{'whose output comes' if resting > 1 else 'its output coming'} to rest once "
                 f"a turn (δ = 2, the largest ripple there is), "
                 f"{'are' if resting > 1 else 'is'} not taken as the knee.")
    if knee is not None and end.name != knee.name and knee["delta"] > 0 and knee[x] != 0:
        more = abs(end[x] - knee[x]) / abs(knee[x])
        cost = (end["delta"] - knee["delta"]) / knee["delta"]
        text += (f" The {best}-{x} end of the front, {x} {end[x]:.5g} at δ {end['delta']:.5f}, "
                 f"gives {100 * more:.3g} % {'more' if axis.sign > 0 else 'less'} {x} than the "
                 f"knee for {100 * cost:.3g} % more ripple.")
    return text


def _nadir(ind, x: str = "ratio") -> str:
    if not ind.get("ideal"):
        return ""
    i, n = ind["ideal"], ind["nadir"]
    return f"({i['delta']:.4f}, {i[x]:.4f}) / ({n['delta']:.4f}, {n[x]:.4f})"


def render_md(items) -> str:
    lines = []
    for item in items:
        kind = item[0]
        if kind == "h1":
            lines += [f"# {item[1]}", ""]
        elif kind == "h2":
            lines += [f"## {item[1]}", ""]
        elif kind == "p":
            lines += [item[1], ""]
        elif kind == "img" and item[2] is not None:
            lines += [f"![{item[1]}]({item[1]})", ""]
        elif kind == "link":
            lines += [f"[{item[2]}]({item[1]})", ""]
        elif kind == "table":
            head, rows = item[1], item[2]
            lines.append("| " + " | ".join(head) + " |")
            lines.append("|" + "---|" * len(head))
            lines += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
            lines.append("")
    return "\n".join(lines)


def render_html(items) -> str:
    body = []
    for item in items:
        kind = item[0]
        if kind in ("h1", "h2", "p"):
            body.append(f"<{kind}>{html.escape(item[1])}</{kind}>")
        elif kind == "img" and item[2] is not None:
            data = base64.b64encode(Path(item[2]).read_bytes()).decode("ascii")
            body.append(f'<img alt="{html.escape(item[1])}" src="data:image/png;base64,{data}">')
        elif kind == "link":
            body.append(f'<p><a href="{html.escape(item[1])}">{html.escape(item[2])}</a></p>')
        elif kind == "table":
            head = "".join(f"<th>{html.escape(str(h))}</th>" for h in item[1])
            rows = "".join("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in r)
                           + "</tr>" for r in item[2])
            body.append(f"<table><thead><tr>{head}</tr></thead><tbody>{rows}</tbody></table>")
    style = ("body{font-family:sans-serif;max-width:1100px;margin:2em auto;color:#222}"
             "table{border-collapse:collapse;margin:1em 0;font-size:13px}"
             "td,th{border:1px solid #ccc;padding:3px 7px;text-align:right}"
             "img{max-width:100%;display:block;margin:1em 0}")
    return (f"<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>Pareto report"
            f"</title><style>{style}</style></head><body>\n" + "\n".join(body) +
            "\n</body></html>\n")


def summary_text(result) -> str:
    """The indicators and the knee, printed by ``optdesign pareto``."""
    ind = result.indicators
    status = result.points["status"]
    local = int((status == LOCAL).sum())
    lines = [f"{len(result.points)} points, {int(status.isin(VERIFIED).sum())} verified feasible"
             + (f" ({local} local: a known design beats them on their own ε)" if local else "")
             + f"; {ind['n_points']} non-dominated over every phase count"]
    if "round" in result.points:
        rounds = result.points["round"].fillna(0)
        uniform = int((rounds == 0).sum())
        lines.append(f"  of the {len(result.points)}: {uniform} from the uniform ε pass "
                     f"(pareto.points per count), {len(result.points) - uniform} added where "
                     f"the front is coarse (pareto.refine; enabled: false keeps the uniform "
                     f"pass alone)")
    for n, v in result.per_count.items():
        lines.append(f"  n = {n}: {v['n_points']} non-dominated, hypervolume "
                     f"{_fmt(v['hypervolume'])}, spacing {_fmt(v['spacing'])}"
                     + (" (one design: no trade-off)" if v["n_points"] == 1 else ""))
    if ind["n_points"] == 1:
        lines.append("one design over every phase count: no trade-off, no hypervolume")
    elif ind["n_points"]:
        lines.append(f"hypervolume {ind['hypervolume']:.4f} (normalised: ideal (0, 0), nadir "
                     f"(1, 1), reference {REFERENCE}); spacing {_fmt(ind['spacing'])}")
    knee = result.knee
    if knee is not None:
        axis = result.axis
        lines.append(f"knee: n = {int(knee['count'])}, δ = {knee['delta']:.5f}, ratio = "
                     f"{knee['ratio']:.5f}" + ("" if axis.is_ratio else
                                               f", {axis.name} = {knee[axis.name]:.5g} "
                                               f"{axis.unit}"))
        lines.append(knee_reason(result))
    return "\n".join(lines)

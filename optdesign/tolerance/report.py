"""What ``optdesign tolerance`` reports: the JSON document, the terminal table and the figure.

Plot functions return the figure and never write (:mod:`optdesign.commands.files` saves it); the
backend is never switched here.
"""
from __future__ import annotations

import numpy as np

from optdesign.evaluation.figures import evaluate_problem
from optdesign.figures.design import pyplot
from optdesign.outputs.units import design_units, stamped
from optdesign.quantities import design_quantities, get_quantity
from optdesign.tolerance.montecarlo import summary


def tolerance_document(problem, box, tolerances, frame, worst_delta, worst_angle,
                       design_source: str) -> dict:
    """tolerance.json: the nominal design's exact figures, both worst cases with their
    deviations, and the Monte Carlo's distributions and shares."""
    nominal = frame.attrs["nominal"]
    stats = summary(frame, problem)
    distribution = getattr(tolerances, "distribution", "uniform")
    monte_carlo = {"parts": stats.pop("parts"), "distribution": distribution,
                   "k": getattr(tolerances, "k", None) if distribution == "normal" else None,
                   "seed": frame.attrs.get("seed"),
                   "crank_samples": frame.attrs["crank_samples"],
                   "wall_time_s": frame.attrs["wall_time_s"]}
    for key in ("delta", "ratio", "mu_min_deg"):
        monte_carlo[f"{key}_distribution"] = stats.pop(key)
    monte_carlo.update(stats)
    doc = {
        "name": problem.name, "mechanism": problem.mechanism, "stroke": problem.stroke,
        "input_speed": problem.input_speed, "ripple": problem.objective.ripple,
        "eccentricities": list(problem.eccentricities),
        "design": {k: float(v) for k, v in box.values.items()},
        "design_source": design_source,
        "tolerances_mm": {k: float(v) for k, v in zip(box.names, box.band)},
        "nominal": {"assembles": nominal["assembles"], "delta": nominal["delta"],
                    "ratio": nominal["ratio"], "mu_min_deg": nominal["mu_min_deg"],
                    "quantities": exact_quantities(problem, box.values)},
        "worst_case": {name: w.to_dict() | {"quantities": exact_quantities(problem, w.lengths)}
                       for name, w in (("delta", worst_delta),
                                       ("transmission_angle", worst_angle))},
        "monte_carlo": monte_carlo,
    }
    return stamped(doc, design_units(problem.mechanism))


def exact_quantities(problem, values) -> dict:
    """Every quantity's exact value of one part (``{"values": ..., "per_eccentricity": ...}``,
    the block of ``analyze``; empty for a part that does not assemble)."""
    return design_quantities(problem, evaluate_problem(problem, dict(values), search=False))


def format_tolerance(doc: dict) -> str:
    """The report as a table for the terminal."""
    mc, nominal = doc["monte_carlo"], doc["nominal"]
    wd, wa = doc["worst_case"]["delta"], doc["worst_case"]["transmission_angle"]
    band = ", ".join(f"{k} ±{v:g}" for k, v in doc["tolerances_mm"].items())
    lines = [f"{doc['name']}: tolerance analysis of {doc['design_source']}",
             f"tolerances (mm): {band}; {mc['distribution']}"
             + (f" (k = {mc['k']:g})" if mc["distribution"] == "normal" else "")
             + f", {mc['parts']} parts",
             "",
             f"{'':<16}{'nominal':>10}{'MC min':>10}{'p5':>10}{'p50':>10}{'p95':>10}"
             f"{'MC max':>10}{'worst':>10}"]

    def row(label, key, value, worst, digits):
        d = mc[f"{key}_distribution"]
        cells = [value] + ([d["min"], d["p5"], d["p50"], d["p95"], d["max"]] if d else
                           [None] * 5) + [worst]
        lines.append(f"{label:<16}" + "".join(
            f"{'-':>10}" if c is None else f"{c:>10.{digits}f}" for c in cells))

    row("δ", "delta", nominal["delta"], wd["delta"], 6)
    row("ratio", "ratio", nominal["ratio"], None, 6)
    row("least μ [deg]", "mu_min_deg", nominal["mu_min_deg"], wa["mu_min_deg"], 3)
    lines.append("")
    for label, w in (("worst δ", wd), ("least μ", wa)):
        where = ", ".join(f"{k} {v:+.4g}" for k, v in w["deviation_mm"].items() if v) or "none"
        state = "" if w["assembles"] else " (does NOT assemble)"
        lines.append(f"{label} part{state}: {where} mm"
                     + (" (a corner of the box)" if w["on_corner"] else " (inside the box)")
                     + f"; {w['exact_evaluations']} exact evaluations")
    lines += _quantity_lines(nominal, wd, wa) + [""]
    shares = [f"not assembling {100 * mc['share_not_assembling']:.2f} %",
              f"μ below {mc['min_transmission_angle_deg']:g}° "
              f"{100 * mc['share_below_min_transmission_angle']:.2f} %"]
    if "share_below_min_ratio" in mc:
        shares.append(f"ratio below {mc['min_ratio']:g} {100 * mc['share_below_min_ratio']:.2f} %")
    if "share_above_max_ripple" in mc:
        shares.append(f"δ above {mc['max_ripple']:g} "
                      f"{100 * mc['share_above_max_ripple']:.2f} %")
    shares += [f"beyond {key} {100 * share:.2f} %"
               for key, share in mc.get("share_outside_bounds", {}).items()]
    shares.append(f"failing any of these {100 * mc['share_failing_any']:.2f} %")
    lines.append("parts: " + "; ".join(shares))
    if mc.get("bounds_not_sampled"):
        lines.append("not in the parts' figures (the worst parts' quantities above are exact): "
                     + ", ".join(mc["bounds_not_sampled"]))
    if mc["share_not_assembling"] > 0 or mc["share_below_min_transmission_angle"] > 0:
        lines.append("some parts break the angle rule or do not assemble: `objective: {robust: "
                     "worst_case}` in the problem file sizes a design whose every part of this "
                     "box assembles and keeps the rule (docs/formulation.md, \"Robust solve\")")
    lines.append(f"Monte Carlo {mc['wall_time_s']:.2f} s on {mc['crank_samples']} crank samples "
                 f"per turn, refined and calibrated on the exact nominal; the nominal and worst "
                 f"cases are exact")
    return "\n".join(lines)


def _quantity_lines(nominal: dict, worst_delta: dict, worst_angle: dict) -> list[str]:
    """Each quantity of the nominal and of the two worst parts, exact, one line each."""
    values = [(part.get("quantities") or {}).get("values", {})
              for part in (nominal, worst_delta, worst_angle)]
    if not values[0]:
        return []
    out = ["", f"{'quantity':<22}{'nominal':>12}{'worst-δ part':>14}{'least-μ part':>14}"]
    for name in values[0]:
        q = get_quantity(name)
        cells = [v.get(name) for v in values]
        out.append(f"{name:<22}" + "".join(
            f"{'-':>{w}}" if c is None else f"{c:>{w}.6g}" for c, w in zip(cells, (12, 14, 14)))
            + f"  {q.unit}")
    return out


def plot_tolerance(frame, doc: dict, title: str | None = None):
    """Histograms of δ, the ratio and the least transmission angle of the parts, with the
    nominal, for δ and μ the worst case over the box, and the file's least angle and ratio
    where they fall inside the spread marked."""
    from matplotlib.ticker import MaxNLocator

    plt = pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
    ok = frame["assembles"].to_numpy()
    nominal, worst = doc["nominal"], doc["worst_case"]
    marks = {"delta": worst["delta"]["delta"], "mu_min_deg": worst["transmission_angle"]
             ["mu_min_deg"], "ratio": None}
    mc = doc["monte_carlo"]           # the file's limits, where it sets them
    limits = {"delta": None, "ratio": mc.get("min_ratio"),
              "mu_min_deg": mc.get("min_transmission_angle_deg")}
    labels = {"delta": "δ (worst over the listed e)", "ratio": "ratio (output / input speed)",
              "mu_min_deg": "least transmission angle μ [deg]"}
    for ax, key in zip(axes, ("delta", "ratio", "mu_min_deg")):
        values = frame[key].to_numpy()[ok]
        if values.size:
            ax.hist(values, bins=60, color="tab:blue", alpha=0.75)
        ax.axvline(nominal[key], color="black", lw=1.5, label="nominal")
        if marks[key] is not None and np.isfinite(marks[key]):
            ax.axvline(marks[key], color="crimson", lw=1.5, ls="--", label="worst case")
        if limits[key] is not None and values.size and \
                values.min() - 0.1 * np.ptp(values) <= limits[key]:    # only when it shows
            ax.axvline(limits[key], color="darkorange", lw=2, ls=":", label="the file's limit")
        ax.set_xlabel(labels[key])
        ax.grid(alpha=0.3)
        ax.ticklabel_format(axis="x", useOffset=False)
        ax.xaxis.set_major_locator(MaxNLocator(5))
        ax.legend(fontsize=8)
    axes[0].set_ylabel("parts")
    rule = "" if mc.get("share_below_min_transmission_angle") is None else \
        f", {100 * mc['share_below_min_transmission_angle']:.2f} % below the " \
        f"{mc['min_transmission_angle_deg']:g}° transmission-angle rule"
    fig.suptitle(title or f"{doc['name']}: {len(frame)} parts, "
                          f"{100 * (1 - ok.mean()):.2f} % not assembling{rule}")
    fig.tight_layout()
    return fig

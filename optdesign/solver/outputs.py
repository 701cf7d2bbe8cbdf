"""The plain-text account of a solve (the files themselves: :func:`optdesign.commands.files.write_solve`)."""
from __future__ import annotations

from optdesign.evaluation.sensitivity import sensitivity_line
from optdesign.outputs.units import gear_ratio_text, input_speed_text
from optdesign.quantities import get_quantity, unit_text
from optdesign.quantities.bounds import side_key
from optdesign.quantities.criteria import (ATTAINED, LengthConstraint, constraints_of,
                                           objective_of, quantity_specs)


def summary_text(result, problem) -> str:
    """A short plain-text account of a solve, for the terminal and summary.txt."""

    strokes = "both strokes" if problem.stroke == "both" else f"{problem.stroke} stroke"
    lines = [f"{problem.name}: {result.status} ({problem.mechanism}, {strokes}, "
             f"{input_speed_text(problem.input_speed)})"]
    lines += least_count_lines(result.least_count, problem.model.count_variable)
    if result.design:
        lengths = set(problem.model.lengths)
        lines.append("design: " + ", ".join(f"{k} = {v:.4f} mm" if k in lengths else
                                            f"{k} = {v:g}" for k, v in result.design.items()))
        named = result.ripples()
        delta = named.worst.text(6) if named is not None else \
            f"δ ({problem.objective.ripple}) = {result.delta:.6f}"
        lines.append(f"{delta}; ratio = {result.ratio:.6f} (output/input speed; "
                     f"gear ratio i = 1/ratio = {gear_ratio_text(result.ratio)}); least "
                     f"transmission angle = {result.min_transmission_angle_deg:.2f} deg")
        if named is not None and len(named.each) > 1:
            lines.append("δ at each: " + "; ".join(r.text(6) for r in named.each))
        values = (result.quantities or {}).get("values", {})
        over = "the listed eccentricities" if problem.eccentricity_range is None else \
            "the listed eccentricities and the interval"
        named = [spec for spec in quantity_specs(problem) if spec.key in values]
        if named:
            lines.append("quantities: " + "; ".join(
                f"{spec.key} = {values[spec.key]:.6g}{unit_text(spec.name)}"
                f"{_where(spec, over)}" for spec in named))
        if result.worst_case_delta is not None:
            best = result.best_phase()
            bounded = "".join(
                f"; the box's worst {key} = {value:.6g}{unit_text(key.split('@')[0])}"
                for key, value in (best.worst_case_quantities if best else {}).items())
            lines.append(f"robust: the worst part of the tolerance box has δ = "
                         f"{result.worst_case_delta:.6f} (the objective){bounded}; every "
                         f"part assembles and keeps every constraint")
        lines.append(binding_text(result.active, problem))
        lines.append(sensitivity_line(result.sensitivities))
        lines += bound_warnings(result, problem)
    else:
        lines.append(result.message)
    lines.append(f"solve time {result.solve_time_s:.2f} s, {result.iterations} IPOPT iterations")
    lines.append("per phase count:")
    for p in result.per_phase:
        if p.status == "optimal":
            gap = f"{p.surrogate_gap:+.1e}" if p.surrogate_gap is not None else "n/a"
            lines.append(f"  n = {p.count}: {p.status}, δ = {p.delta:.6f}, ratio = "
                         f"{p.ratio:.4f}, surrogate gap {gap}, {len(p.starts)} "
                         f"start{'' if len(p.starts) == 1 else 's'}")
        else:
            lines.append(f"  n = {p.count}: {p.status}: {p.message}")
    lines.append("every figure above is the exact evaluator's, not the NLP surrogate's")
    return "\n".join(lines)


def least_count_lines(record: dict, name: str) -> list[str]:
    """With ``minimize: phases``: the least count meeting the ripple cap, the least δ of
    each count below it (why it fails) and what was not solved; nothing otherwise."""
    if not record:
        return []
    bound = f"δ ≤ {record['bound']:g} ({record['key']})"
    below = [r for r in record["counts"] if not r["meets"]]
    if record["count"] is None:
        head = f"least count for {bound}: none of the admissible {name} meets it"
    else:
        head = f"least count for {bound}: {name} = {record['count']}"
    lines = [head + (" (each count solved for its least δ)" if not below else "")]
    if below:
        lines.append("the least δ of each count " + ("below it" if record["count"] is not None
                                                       else "solved") + ": " + "; ".join(
            f"n = {r['count']}: {r['delta']:.6f} > {record['bound']:g}"
            if r["status"] == "infeasible" and r["delta"] is not None
            else f"n = {r['count']}: {r['status']} ({r['message']})" for r in below))
    if record["unsettled"] and record["count"] is not None:
        lines.append(f"warning: the solve of {name} = "
                     f"{', '.join(str(n) for n in record['unsettled'])} found no verified "
                     f"optimum and no verdict: a smaller count may meet the bound")
    if record["not_solved"]:
        lines.append(f"{name} = {', '.join(str(n) for n in record['not_solved'])}: not solved "
                     f"(a larger count than the least)")
    return lines


def binding_text(active: list[dict], problem) -> str:
    """One line: what binds at the optimum and what relaxing it by one unit buys."""
    if not active:
        return "binding: nothing (an interior optimum: no bound or constraint is active)"
    what = objective_of(problem).symbol
    return "binding: " + "; ".join(
        f"{_bound_name(a['name'], problem)} (d{what}/d bound = {a['sensitivity']:+.3g}"
        f"{'' if a['unit'] == '-' else ' per ' + a['unit']})" for a in active)


def _bound_name(name: str, problem) -> str:
    """A binding row's name as the designer wrote it: a bound on a quantity by its file key
    (``constraints.ratio.upper``: the NLP's row ``ratio.attained`` holds a cap on the ratio),
    every other row by its own name."""
    base = name[:-len(ATTAINED)] if name.endswith(ATTAINED) else name
    spec = next((s for s in quantity_specs(problem) if s.key == base), None)
    if spec is None:
        return name
    natural = get_quantity(spec.name).natural_side()
    side = natural if base == name else ("lower" if natural == "upper" else "upper")
    return side_key(problem.constraints.spelled, spec, side)


def bound_warnings(result, problem) -> list[str]:
    """A warning per free length the optimum rests on a bound of: the design would go past
    it, so the bound shapes the result (is it a real limit, or a first guess?); and one per
    length constraint held at zero, where the linkage degenerates (in the mechanism's words,
    its ``at_zero``)."""
    criteria = {c.name: c for c in constraints_of(problem)}
    out = []
    for a in result.active:
        criterion = criteria.get(a["name"])
        if isinstance(criterion, LengthConstraint):
            lower, upper = criterion.bounds(problem)
            if (lower if a["side"] == "lower" else upper) == 0:
                why = f" ({criterion.at_zero})" if criterion.at_zero else ""
                out.append(f"warning: {a['name']} is held at 0 {a['unit']}: the linkage "
                           f"degenerates there{why}; give the constraint a real least value "
                           f"in the problem file")
    for a in result.active:
        if a["kind"] != "bound":
            continue
        key = a["name"].split()[0]
        spec = problem.design[key]
        value = spec.lower if a["side"] == "lower" else spec.upper
        out.append(f"warning: {key} rests on its {a['side']} bound, {value:g} mm: the "
                   f"optimum would go past it (d{objective_of(problem).symbol}/d bound = "
                   f"{a['sensitivity']:+.3g} per mm); check that the bound is a real limit")
    return out


def _where(spec, over: str) -> str:
    """Where a bounded quantity's value in the summary is read: at its own eccentricity
    (``swing@0.5``, its key says so), at the quantity's (the ratio, at e = 1), else its worst
    over ``over``."""
    if spec.at is not None:
        return ""
    at = get_quantity(spec.name).at
    return f" (at e = {at:g})" if at is not None else f" (worst over {over})"

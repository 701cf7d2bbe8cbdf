"""The robust solve's parts (``objective.robust: worst_case``): which parts of the tolerance box
the NLP holds as scenarios, and the verdict on a robust optimum.

The tolerance analysis (:mod:`optdesign.tolerance.worst_case`) finds the box's worst part for δ,
for the transmission angle (assembly included) and for every bound on a quantity; those become
scenario slots of the NLP (:class:`~optdesign.solver.nlp.Held`), whose rows hold every
constraint at each held part. The verdict: the worst δ ranks the optimum; the worst angle's
part and each bound's worst part must keep their bounds, and the constraints on the lengths and
the ratio floor are checked at every corner of the box.
"""
from __future__ import annotations

import itertools
import math
from dataclasses import replace

import numpy as np

from optdesign.quantities.criteria import (LengthConstraint, Measured, TOL_ANGLE_DEG, TOL_RATIO,
                                           bound_excess, constraints_of)
from optdesign.solver.nlp import Held, SCENARIO_SLOTS
from optdesign.solver.verify import Verification
from optdesign.tolerance.exact_part import exact_part
from optdesign.tolerance.parts import box_of
from optdesign.tolerance.worst_case import worst_case

#: a robust solve ends when the tolerance box's worst δ exceeds the NLP's bound t by less
ROBUST_TOL = 1e-6
#: the corners of a box of at most this many toleranced lengths are all checked
MAX_CORNER_DIMS = 8


def worst_cases(problem, values) -> tuple:
    """The tolerance analysis of ``values``: the worst part for δ, for the transmission
    angle and for each bound on a quantity, by its key
    (:func:`optdesign.tolerance.worst_case.worst_case`), and the box's corners that break a
    constraint on the lengths or the ratio floor (:func:`corner_violations`)."""
    tolerances = problem.sections["tolerances"]
    keys = ("ripple", "transmission_angle") + tuple(s.key for s in problem.constraints.quantities)
    return tuple(worst_case(problem, values, tolerances, quantity=q) for q in keys), \
        corner_violations(problem, values)


def broken_bound(problem, case) -> float:
    """How far the worst part ``case`` of a bound's quantity lies outside the bound (<= 0
    when it keeps it, inf when the part does not assemble)."""
    if not case.assembles:
        return math.inf
    spec = next(s for s in problem.constraints.quantities if s.key == case.quantity)
    return bound_excess(spec, case.value)


def next_scenarios(problem, held: Held, worst_cases, bound: float | None = None,
                   corners: dict | None = None) -> Held:
    """The scenario slots after a tolerance analysis: the worst part for δ (when its δ
    exceeds the NLP's ``bound`` t by more than ROBUST_TOL, or always without one) and the worst
    part for the transmission angle (when it breaks the bound or does not assemble) are held,
    and so is the worst corner of each constraint that ``corners``
    (:func:`corner_violations`) finds broken; the oldest held part makes room when every slot
    is in use (the part wanted least recently; one wanted again is kept)."""
    wanted = []
    ripple, angle, *bounded = worst_cases
    if not ripple.assembles or bound is None or ripple.value > bound + ROBUST_TOL:
        wanted.append(ripple)
    if not angle.assembles or \
            angle.value < problem.constraints.min_transmission_angle_deg - TOL_ANGLE_DEG:
        wanted.append(angle)
    wanted += [case for case in bounded if broken_bound(problem, case) > 0]
    names = problem.model.lengths
    wanted = [tuple(float(case.deviation[k]) for k in names) for case in wanted]
    wanted += [offsets for _, offsets in (corners or {}).values()]
    kept = [o for o, a in zip(held.offsets, held.scenario_active) if a]
    for offsets in wanted:          # a part wanted again moves to the back of the queue
        kept = [o for o in kept if not np.allclose(offsets, o, rtol=0.0, atol=1e-9)]
        kept = (kept + [offsets])[-SCENARIO_SLOTS:]
    zero = (0.0,) * len(names)
    pad = SCENARIO_SLOTS - len(kept)
    return replace(held, offsets=tuple(kept) + (zero,) * pad,
                   scenario_active=(True,) * len(kept) + (False,) * pad)


def robust_verdict(problem, values, ver: Verification) -> None:
    """A robust optimum ranks by the tolerance box's worst δ, and is feasible only if every
    part assembles and keeps the transmission angle and every bound on a quantity (the
    tolerance analysis's word) and every corner of the box keeps the constraints on the
    lengths and the ratio floor."""
    if not ver.worst_cases:
        ver.feasible, ver.key = False, math.inf
        ver.violations.setdefault("robust", math.inf)
        return
    ripple, angle, *bounded = ver.worst_cases
    ver.key = ripple.value if ripple.assembles else math.inf
    deficit = problem.constraints.min_transmission_angle_deg - angle.value
    if not (ripple.assembles and angle.assembles):
        ver.violations["robust_assembly"] = math.inf
        ver.feasible = False
    elif deficit > TOL_ANGLE_DEG:
        ver.violations["robust_transmission_angle"] = deficit
        ver.feasible = False
    for case in bounded:
        amount = broken_bound(problem, case)
        if amount > 0:
            ver.violations[f"robust_{case.quantity}"] = amount
            ver.feasible = False
    for name, (amount, _) in ver.corners.items():
        ver.violations[f"robust_{name}"] = amount
        ver.feasible = False


def corner_violations(problem, values) -> dict[str, tuple[float, tuple[float, ...]]]:
    """The constraints on the lengths and the ratio floor at every corner of the tolerance box
    (every toleranced length at ± its tolerance): {name: (largest violation, that corner's
    offsets)} of those broken.
    A constraint linear in the lengths is worst at a corner; the ratio is monotone in each
    length over so small a box."""

    box = box_of(problem, values, problem.sections["tolerances"])
    dims = box.toleranced
    if dims.size > MAX_CORNER_DIMS:
        return {}
    length_rules = [c for c in constraints_of(problem) if isinstance(c, LengthConstraint)]
    out: dict[str, float] = {}
    for signs in itertools.product((-1.0, 1.0), repeat=dims.size):
        offsets = np.zeros(box.band.size)
        offsets[dims] = np.array(signs) * box.band[dims]
        part = box.part(offsets)
        lengths = {k: part[k] for k in problem.model.lengths}
        for rule in length_rules:
            m = Measured(lengths, math.nan, math.nan, math.nan, math.nan, None)
            amount = float(rule.violation(problem, m))
            if amount > rule.tolerance(m) and amount > out.get(rule.name, (-math.inf,))[0]:
                out[rule.name] = (amount, tuple(offsets))
        if problem.objective.min_ratio > 0:
            ratio = exact_part(problem, part)["ratio"]
            short = problem.objective.min_ratio - ratio
            short = short if math.isfinite(short) else math.inf
            if not ratio >= problem.objective.min_ratio - TOL_RATIO and \
                    short > out.get("min_ratio", (-math.inf,))[0]:
                out["min_ratio"] = (short, tuple(offsets))
    return out

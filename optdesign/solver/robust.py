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

from optdesign.lifetime import beside
from optdesign.quantities import get_quantity
from optdesign.quantities.criteria import (LengthConstraint, Measured, TOL_ANGLE_DEG, TOL_RATIO,
                                           bound_excess, constraints_of)
from optdesign.solver.nlp import Held, SCENARIO_SLOTS
from optdesign.solver.verify import Verification
from optdesign.tolerance.exact_part import exact_part
from optdesign.tolerance.montecarlo import evaluate_offsets
from optdesign.tolerance.parts import box_of
from optdesign.tolerance.worst_case import WorstCase, prime, worst_case

#: a robust solve ends when the tolerance box's worst δ exceeds the NLP's bound t by less
ROBUST_TOL = 1e-6
#: the corners of a box of at most this many toleranced lengths are all checked
MAX_CORNER_DIMS = 8
#: a corner whose screened ratio lies this close to the floor is measured exactly (the
#: vectorised evaluator's ratio is within 1e-8 of the exact one over a tolerance box)
RATIO_SCREEN_MARGIN = 1e-6


def worst_cases(problem, values, in_parallel: bool = False) -> tuple:
    """The tolerance analysis of ``values``: the worst part for δ, for the transmission
    angle and for each bound on a quantity, by its key
    (:func:`optdesign.tolerance.worst_case.worst_case`), and the box's corners that break a
    constraint on the lengths or the ratio floor (:func:`corner_violations`).

    The box's nominal and start pool are evaluated once for every search; ``in_parallel``:
    the searches after δ's run in a forked child beside it (two cores; the same results)."""
    tolerances = problem.sections["tolerances"]
    keys = ("ripple", "transmission_angle") + tuple(s.key for s in problem.quantity_bounds)
    shared: dict = {}

    def search(names):
        return [worst_case(problem, values, tolerances, quantity=q, shared=shared)
                for q in names]
    if not in_parallel:
        return tuple(search(keys)), corner_violations(problem, values, shared)
    prime(problem, values, tolerances, shared)
    others = beside(search, keys[1:])
    try:
        ripple = search(keys[:1])
        corners = corner_violations(problem, values, shared)
    except BaseException:               # a Ctrl-C, an error: the child is not waited for
        others.cancel()
        raise
    return tuple(ripple + others()), corners


def screened_cases(problem, values) -> tuple:
    """A first look at the tolerance box of ``values``, cheaper than :func:`worst_cases` and
    in the same form: every corner ranked on the vectorised evaluator
    (:func:`~optdesign.tolerance.montecarlo.evaluate_offsets`), the corner of the largest δ
    and the one of the least transmission angle each measured exactly, and the corners that
    break a constraint on the lengths or the ratio floor (:func:`corner_violations`). The
    worst parts of a smooth δ and μ over so small a box are mostly corners; the full analysis
    certifies the optimum where this look finds nothing new. Third, the runners-up: the other
    corners, the roughest and the least angled in turn, each apart from those before it in
    two lengths or more (offsets, mm), to fill the slots a first solve leaves free. A box of
    more than :data:`MAX_CORNER_DIMS` toleranced lengths gets the full analysis (and no
    runners-up)."""
    box = box_of(problem, values, problem.sections["tolerances"])
    dims = box.toleranced
    if dims.size > MAX_CORNER_DIMS:
        return (*worst_cases(problem, values), [])
    memo: dict = {}
    corners = _corners(box)
    figures, nominal = evaluate_offsets(problem, box, corners, memo=memo)
    memo["nominal"], memo["corners"] = nominal, figures
    fine = figures["assembles"]
    picks = (("ripple", int(np.argmax(np.where(fine, figures["delta"], np.inf))), "delta"),
             ("transmission_angle",
              int(np.argmin(np.where(fine, figures["mu_min_deg"], -np.inf))), "mu_min_deg"))
    cases = []
    for quantity, i, key in picks:
        part = box.part(corners[i])
        exact = exact_part(problem, part)
        # a part that does not assemble counts as the worst there is
        folded = math.inf if get_quantity(quantity).worst == "max" else 0.0
        cases.append(WorstCase(quantity, exact[key] if exact["assembles"] else folded,
                               box.deviation(corners[i]),
                               {k: float(v) for k, v in part.items()}, 1, exact["assembles"],
                               nominal[key], on_corner=True, starts=len(corners)))
    roughest = np.argsort(-np.where(fine, figures["delta"], np.inf), kind="stable")
    least_angled = np.argsort(np.where(fine, figures["mu_min_deg"], -np.inf), kind="stable")
    order = [i for pair in zip(roughest, least_angled) for i in pair]
    signs = np.sign(corners[:, dims])
    chosen = [picks[0][1], picks[1][1]]
    for i in order:
        if all(np.count_nonzero(signs[i] != signs[j]) >= 2 for j in chosen):
            chosen.append(i)
    runners_up = [tuple(float(v) for v in corners[i]) for i in chosen[2:]]
    return tuple(cases), corner_violations(problem, values, memo), runners_up


def _corners(box) -> np.ndarray:
    """The offsets of every corner of ``box`` (2^d × the mechanism's lengths, mm)."""
    dims = box.toleranced
    corners = np.zeros((2 ** dims.size, box.band.size))
    corners[:, dims] = np.array(list(itertools.product((-1.0, 1.0), repeat=dims.size))) * \
        box.band[dims]
    return corners


def broken_bound(problem, case) -> float:
    """How far the worst part ``case`` of a bound's quantity lies outside the bound (<= 0
    when it keeps it, inf when the part does not assemble)."""
    if not case.assembles:
        return math.inf
    spec = next(s for s in problem.quantity_bounds if s.key == case.quantity)
    return bound_excess(spec, case.value)


def next_scenarios(problem, held: Held, worst_cases, bound: float | None = None,
                   corners: dict | None = None, fill=(), binding=()) -> Held:
    """The scenario slots after a tolerance analysis: the worst part for δ (when its δ
    exceeds the NLP's ``bound`` t by more than ROBUST_TOL, or always without one) and the worst
    part for the transmission angle (when it breaks the bound or does not assemble) are held,
    and so is the worst corner of each constraint that ``corners``
    (:func:`corner_violations`) finds broken. When every slot is in use, a held part that
    does not bind (not in ``binding``: the offsets of the held parts whose rows carry a
    multiplier at the last solution) makes room, the one wanted least recently first; the
    oldest binding part only when every held part binds. The parts ``fill`` (offsets, mm)
    take the slots still free, in order."""
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
    for n, offsets in enumerate(wanted):    # a part wanted again moves to the back
        kept = [o for o in kept if not _same(offsets, o)] + [offsets]
        if len(kept) > SCENARIO_SLOTS:
            older = [o for o in kept if not any(_same(o, w) for w in wanted[:n + 1])]
            idle = [o for o in older if not any(_same(o, b) for b in binding)]
            drop = (idle or older or kept)[0]
            kept = [o for o in kept if o is not drop]
    for offsets in fill:
        if len(kept) < SCENARIO_SLOTS and not any(_same(offsets, o) for o in kept):
            kept.append(tuple(offsets))
    zero = (0.0,) * len(names)
    pad = SCENARIO_SLOTS - len(kept)
    return replace(held, offsets=tuple(kept) + (zero,) * pad,
                   scenario_active=(True,) * len(kept) + (False,) * pad)


def _same(a, b) -> bool:
    """Two parts' offsets are one part."""
    return bool(np.allclose(a, b, rtol=0.0, atol=1e-9))


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


def corner_violations(problem, values, memo: dict | None = None
                      ) -> dict[str, tuple[float, tuple[float, ...]]]:
    """The constraints on the lengths and the ratio floor at every corner of the tolerance box
    (every toleranced length at ± its tolerance): {name: (largest violation, that corner's
    offsets)} of those broken.
    A constraint linear in the lengths is worst at a corner; the ratio is monotone in each
    length over so small a box. The ratio of every corner is screened on the vectorised
    evaluator (:func:`~optdesign.tolerance.montecarlo.evaluate_offsets`, ``memo`` as there)
    and measured exactly where the screen is within :data:`RATIO_SCREEN_MARGIN` of the floor
    or fails (the screen's figures are ``memo["corners"]`` when a caller has them)."""
    box = box_of(problem, values, problem.sections["tolerances"])
    dims = box.toleranced
    if dims.size > MAX_CORNER_DIMS:
        return {}
    length_rules = [c for c in constraints_of(problem) if isinstance(c, LengthConstraint)]
    corners = _corners(box)
    near_floor = np.zeros(len(corners), dtype=bool)
    if problem.constraints.min_ratio > 0:
        screened = (memo or {}).get("corners") or evaluate_offsets(
            problem, box, corners, memo=memo, nominal=(memo or {}).get("nominal"))[0]
        near_floor = ~(screened["ratio"] >= problem.constraints.min_ratio - TOL_RATIO +
                       RATIO_SCREEN_MARGIN)
    out: dict[str, float] = {}
    for offsets, check_ratio in zip(corners, near_floor):
        part = box.part(offsets)
        lengths = {k: part[k] for k in problem.model.lengths}
        for rule in length_rules:
            m = Measured(lengths, math.nan, math.nan, math.nan, math.nan, None)
            amount = float(rule.violation(problem, m))
            if amount > rule.tolerance(m) and amount > out.get(rule.name, (-math.inf,))[0]:
                out[rule.name] = (amount, tuple(offsets))
        if check_ratio:
            ratio = exact_part(problem, part)["ratio"]
            short = problem.constraints.min_ratio - ratio
            short = short if math.isfinite(short) else math.inf
            if not ratio >= problem.constraints.min_ratio - TOL_RATIO and \
                    short > out.get("min_ratio", (-math.inf,))[0]:
                out["min_ratio"] = (short, tuple(offsets))
    return out

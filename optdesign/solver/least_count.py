"""The least count for a target: ``objective: {minimize: phases}`` with a ripple cap.

"How many phases do I need for δ ≤ 0.15?" The admissible counts are solved in increasing
order, each for its least δ under every other constraint (the secondary objective: the same
solve as an atlas cell's, :mod:`optdesign.atlas.worker`, and the relaxed solve that tells how
far a ripple cap is out of reach, :mod:`optdesign.solver.reachable`), until one's least δ meets
the cap. That count is the answer and its least-δ design its optimum; each count below it is
``infeasible`` with its verified least δ as the reachable value (why it fails), or with the
reason another constraint gives; the counts above it are not solved.

A count below the answer whose solve ``failed`` (no verified optimum, no verdict) leaves the
answer unproven: the record lists it under ``unsettled`` and the summary says so.
"""
from __future__ import annotations

import time
from dataclasses import replace

from optdesign.quantities import get_quantity
from optdesign.quantities.criteria import RippleCap
from optdesign.solver.driver import solve_phase, summarized
from optdesign.solver.reachable import Reach
from optdesign.solver.result import PhaseResult, SolveResult
from optdesign.solver.verify import verify

#: the objective a count is solved for (what ``least_count.secondary`` says)
SECONDARY = "ripple"


def per_count(problem):
    """The problem each count is solved as: the least δ under every constraint of
    ``problem`` but the ripple cap (an atlas cell's problem, with the file's constraints)."""
    return replace(problem, objective=replace(problem.objective, minimize=SECONDARY)
                   ).with_limit("ripple", "upper", None)


def least_count(problem, progress=None) -> SolveResult:
    """Solve ``problem`` (``minimize: phases``): the least admissible count whose least δ is
    at most ``objective.max_ripple``, with that count's optimum.

    Parameters
    ----------
    problem : Problem
        A loaded problem with ``objective.minimize == "phases"`` (the loader has checked that
        it has a ripple cap and several admissible counts).
    progress : callable, optional
        Called once per count solved.

    Returns
    -------
    SolveResult
        As :func:`optdesign.solver.driver.solve`'s, with ``per_phase`` holding the counts
        solved (up to the answer) and ``least_count`` the record of the search
        (docs/contract.md).
    """
    t0 = time.perf_counter()
    cap = problem.constraints.max_ripple
    each = per_count(problem)
    name = problem.model.count_variable
    per_phase: list[PhaseResult] = []
    rows: list[dict] = []
    optima: list[dict] = []         # each count's least-δ design: the next count's neighbour
    found = None
    counts = problem.counts()
    for n in counts:
        result = solve_phase(each, n, neighbours=optima[-1:])
        if result.design is not None:
            optima.append(result.design)
        judged, row = _judged(problem, result, cap, name)
        per_phase.append(judged)
        rows.append(row)
        if progress:
            progress()
        if row["meets"]:
            found = n
            break
    out = summarized(problem, per_phase, t0)
    if found is None and all(p.binding == RippleCap.name for p in per_phase):
        least = min(rows, key=lambda r: r["delta"])
        out.message = (f"no admissible count meets {RippleCap().key(problem)} at most {cap:g}: "
                       f"the least δ any of them reaches is {least['delta']:.6g}, with "
                       f"{least['count']} {name} (verified), under every other constraint")
    out.least_count = {
        "count": found, "bound": cap, "key": RippleCap().key(problem), "secondary": SECONDARY,
        "counts": rows,
        "not_solved": [n for n in counts if found is not None and n > found],
        "unsettled": [r["count"] for r in rows if r["status"] == "failed"]}
    return out


def _judged(problem, result: PhaseResult, cap: float, name: str) -> tuple[PhaseResult, dict]:
    """A count's least-δ solve judged against the cap: (its entry in ``per_phase``, its row
    of ``least_count.counts``). A least δ above the cap makes the count ``infeasible``,
    the verified least δ its reachable value."""
    row = {"count": result.count, "status": result.status, "delta": result.delta,
           "ratio": result.ratio, "meets": False, "message": result.message}
    if result.status != "optimal":     # another constraint out of reach, or no verdict
        return result, row
    ver = verify(problem, result.design)
    if ver.feasible:
        row["meets"] = True
        return result, row
    others = sorted(set(ver.violations) - {RippleCap.name})
    if others:          # the least-δ optimum broke another constraint under the capped check
        message = f"the least-δ design violates {', '.join(others)}" + (
            f" ({ver.message})" if ver.message else "")
        row |= {"status": "failed", "message": message}
        return PhaseResult(result.count, "failed", iterations=result.iterations,
                           starts=result.starts, screening=result.screening,
                           timings=result.timings, message=message), row
    quantity = get_quantity("ripple")
    reach = Reach(RippleCap.name, quantity.words or "ripple", float(cap), float(result.delta),
                  "least", quantity.unit, RippleCap().key(problem), dict(result.design))
    message = reach.text(name, result.count)
    row |= {"status": "infeasible", "message": message}
    return PhaseResult(result.count, "infeasible", iterations=result.iterations,
                       starts=result.starts, binding=RippleCap.name, message=message,
                       screening=result.screening, timings=result.timings,
                       reachable=reach.to_dict()), row

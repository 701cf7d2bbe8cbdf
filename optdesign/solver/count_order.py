"""Which phase counts a solve polishes, and in which order: where the ripple is minimised,
the most promising count first, and none whose every sampled design lies far behind the
best optimum found.

A count's *promise* is the least sampled δ of any design of its box's sample that assembles,
every other constraint aside (:func:`optdesign.solver.screening.promise`: the screening's own
sample and grid, scored once and handed on to the count's screening). The constraints only
raise a count's optimum above that relaxed least δ; the polish goes below it where the sample
is coarse. Measured on every count of the shipped problems and of two hundred random ones
(``benchmarks/count_promise.py``): with the ripple minimised in a box of less than two decades
the promise was at most 1.9 times the optimum (the optimum 0.90 of itself below it); in boxes
of decades up to 2.7 times, and with other objectives (a largest peak speed, a largest swing)
the sample's best says little about the optimum. So the counts are ranked only where the
objective is the ripple and no range of the box spans :data:`~optdesign.solver.screening.LOG_SPAN`.

There the counts are solved least promise first (ties by count), each after the first with the
optimum of the last one polished among its screened designs (continuation: the optimum of a
neighbouring count often lies in the best basin of the next). A count whose promise is more
than three times the least verified δ so far (above it by :data:`MARGIN` of it) is not
polished: its status is :data:`OUTRANKED`, and its message gives both figures. What the
answer claims stays true: no design the solve knows of beats it (each of an outranked count's
sampled designs is three times as rough), and the count is not called infeasible. Elsewhere
every count is polished, in increasing order, each with the optimum of the count before it.
"""
from __future__ import annotations

import math

from optdesign.quantities.criteria import objective_of
from optdesign.solver.nlp import is_robust
from optdesign.solver.result import PhaseResult
from optdesign.solver.screening import Scored, of_decades, promise

#: a count is not polished where its promise exceeds the least δ found by more than this share
#: of it (a promise above 3 × the least δ; the largest measured: 1.9 × its own optimum)
MARGIN = 2.0
#: the status of a count not polished (the solve's other statuses: optimal, infeasible, failed)
OUTRANKED = "outranked"


def ranks(problem) -> bool:
    """Whether a solve of ``problem`` ranks its counts (see the module's text): several
    counts, free lengths in a box of less than two decades, the ripple minimised, nominal."""
    return (len(problem.counts()) > 1 and bool(problem.free_lengths()) and
            problem.objective.minimize == "ripple" and not of_decades(problem) and
            not is_robust(problem))


def ranked(problem) -> list[tuple[int, Scored | None]]:
    """The counts in the order a solve polishes them, each with its :func:`promise` (None
    where the solve does not rank them: every count in increasing order)."""
    counts = problem.counts()
    if not ranks(problem):
        return [(n, None) for n in counts]
    scored = {n: promise(problem, n, problem.solver.screen) for n in counts}
    return sorted(scored.items(), key=lambda item: (item[1].promise, item[0]))


def outranked(problem, scored: Scored | None, best: PhaseResult | None) -> bool:
    """Whether the count of ``scored`` cannot beat ``best``, the best optimum so far: its
    promise exceeds best's δ by more than :data:`MARGIN` of it."""
    if scored is None or best is None or not math.isfinite(scored.promise):
        return False
    key = objective_of(problem).result_key(best)
    return scored.promise > key + MARGIN * abs(key)


def outranked_result(problem, scored: Scored, best: PhaseResult) -> PhaseResult:
    """The record of a count not polished: its promise against the best optimum."""
    message = (f"not polished: the least sampled δ of its designs that assemble (every other "
               f"constraint aside) is {scored.promise:.6g}, more than {1 + MARGIN:g} times "
               f"the least δ found, {best.delta:.6g} ({problem.model.count_variable} = "
               f"{best.count})")
    return PhaseResult(scored.count, OUTRANKED, message=message,
                       screening={"designs": len(scored.X), "promise": scored.promise},
                       timings={"build": 0.0, "screening": scored.seconds, "ipopt": 0.0,
                                "verification": 0.0})

"""The units of work of a sweep: one end-point solve or one ε point of one phase count.

These functions run in worker processes (or on Dask workers): they take and return plain data
(the frozen problem and dicts of floats), and each process keeps the NLPs it has built
(:mod:`optdesign.solver.built`) so consecutive points of a chain re-solve the same NLP with a
new ε parameter instead of rebuilding it. Each task solves on a :class:`PhaseSolver` of its
own: a solver kept from the worker's earlier tasks would hand a solve the NLP of more
hand-over slots an earlier point needed, on which IPOPT takes another path, so a point's
iterations and last digits would depend on which points its worker happened to run before.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from typing import Any

from optdesign.errors import OptDesignError
from optdesign.evaluation.sensitivity import sensitivity_record
from optdesign.fronts.axis import axis_of
from optdesign.quantities import design_quantities
from optdesign.quantities.criteria import LengthConstraint, constraints_of
from optdesign.solver import PhaseSolver, solve_phase
from optdesign.solver.starts import start_designs

#: the ripple cap of the largest-ratio solve: loose (midrange δ never exceeds 2)
LOOSE_MAX_RIPPLE = 10.0
#: the largest-ratio design is re-solved for least ripple at this fraction below its ratio
END_RATIO_BACKOFF = 1e-7

def criteria_columns(problem, values: dict) -> dict:
    """The report columns the problem's criteria give a design (e.g. the four-bar's pin
    radius, as its mechanism computes it under the file's pin layout)."""
    lengths = {k: float(values[k]) for k in problem.model.lengths}
    out = {}
    for c in constraints_of(problem):
        if isinstance(c, LengthConstraint) and c.column:
            out[c.column] = float(c.formula(lengths))
    return out


@dataclass
class _Point:
    """One grid point or end of a phase count's front, and the work spent on it."""

    problem: Any
    count: int
    tag: Any                     # grid index, or the end's kind
    kind: str                    # least_ripple | largest_ratio | sweep
    epsilon: float | None = None
    iterations: int = 0
    tries: int = 0
    t0: float = field(default_factory=time.perf_counter)

    def record(self, status: str, values: dict | None = None, figures=None,
               multiplier: float | None = None, ipopt_status: str = "", note: str = "",
               active: list | None = None, limited_by: list | None = None) -> dict:
        """The journal's record; ``figures`` has ``delta``, ``ratio``, ``min_angle_deg``;
        ``active``: what binds at the point (the solve's active set); ``limited_by``: at the
        largest-ratio end, what stops the ratio from growing further."""
        problem, feasible = self.problem, status == "optimal"
        design = {k: float(values[k]) for k in problem.model.lengths} if values else {}
        if design:
            design[problem.model.count_variable] = self.count
        exact = figures is not None and feasible
        columns = criteria_columns(problem, values or problem.start_values())
        quantities = _quantities(problem, figures) if exact else None
        axis = axis_of(problem)
        value = axis.value_of({"quantities": quantities}) if exact else None
        gain = {} if axis.is_ratio else {       # the front's second objective, and its slope
            axis.name: value, "gain": axis.sign * value if value is not None else None,
            "gain_multiplier": None if multiplier is None else axis.sign * multiplier}
        return {"key": [self.count, self.tag], "count": self.count,
                "phases": self.count,         # the count's name before "count", one release
                "kind": self.kind,
                "epsilon": self.epsilon, "status": status, "feasible": feasible,
                "design": design,
                "delta": figures.delta if exact else None,
                "ratio": figures.ratio if exact else None,
                "min_transmission_angle_deg": figures.min_angle_deg if exact else None,
                "sensitivities": sensitivity_record(
                    problem, design, getattr(figures, "evaluation", None)) if exact else None,
                "quantities": quantities, **gain,
                **{k: (v if feasible else None) for k, v in columns.items()},
                "ratio_multiplier": multiplier if axis.is_ratio else None,
                "binding": "; ".join(a["name"] for a in active or []),
                "ratio_limited_by": "; ".join(a["name"] for a in limited_by or []),
                "ipopt_status": ipopt_status,
                "iterations": self.iterations, "tries": self.tries,
                "time_s": time.perf_counter() - self.t0, "note": note}


def solve_end(problem, count: int, kind: str) -> dict:
    """One end of a phase count's front.

    ``least_ripple``: the plain multi-start solve (the ratio bound is the problem's own).
    ``largest_ratio``: maximise the ratio under a loose ripple cap, then re-minimise δ with the
    ratio held at that value (a lexicographic optimum, so the end point is not dominated).
    """
    point = _Point(problem, count, kind, kind)
    axis = axis_of(problem)
    if kind == "least_ripple":
        res = solve_phase(problem, count, solver=PhaseSolver(problem, count))
        point.iterations, point.tries = res.iterations, len(res.starts)
        if res.status != "optimal":
            return point.record(res.status, note=res.message)
        slack = res.ratio - problem.constraints.min_ratio > 1e-6 if axis.is_ratio else True
        return point.record("optimal", res.design, _Ver.of(res), 0.0 if slack else None,
                            "Solve_Succeeded", active=res.active)
    q = largest_gain_problem(problem)
    res = solve_phase(q, count, solver=PhaseSolver(q, count))
    point.iterations, point.tries = res.iterations, len(res.starts)
    if res.status != "optimal":
        return point.record(res.status, note=res.message)
    limits = [a for a in res.active if a["name"] not in ("max_ripple", axis.name)]
    gain = axis.gain_of({"ratio": res.ratio, "quantities": res.quantities})
    epsilon = gain * (1 - END_RATIO_BACKOFF) if gain >= 0 else gain * (1 + END_RATIO_BACKOFF)
    outcome = PhaseSolver(problem, count).solve_from(dict(res.design), **_bound(axis, epsilon))
    rec, ver = outcome.record, outcome.verification
    point.iterations += rec.iterations
    if rec.feasible and ver.delta <= res.delta:
        point.tries, point.epsilon = point.tries + 1, epsilon
        return point.record("optimal", outcome.values, ver,
                            _multiplier(axis, rec) if rec.ipopt_status == "Solve_Succeeded"
                            else None, rec.ipopt_status, active=rec.active,
                            limited_by=limits) | {"warm": outcome.warm}
    return point.record("optimal", res.design, _Ver.of(res), None, "Solve_Succeeded",
                        active=res.active, limited_by=limits)


def largest_gain_problem(problem):
    """The first solve of the largest-ratio end: the gain (the ratio, or the axis's
    quantity) maximised under a ripple cap of :data:`LOOSE_MAX_RIPPLE`, on the exact Hessian
    whatever ``solver.hessian`` says. The limited-memory Hessian ran out of its iterations
    on the largest ratio of pareto_fourbar at both counts (then the exact Hessian's retry
    converged in 33), and the whole end took 1.5 to 7 times the iterations it takes on the
    exact one on the other fronts of ``benchmarks/pareto_vs_peers.py``, to the same ratio."""
    axis = axis_of(problem)
    return replace(problem, objective=replace(problem.objective, minimize=axis.objective),
                   solver=replace(problem.solver, hessian="exact")
                   ).with_limit("ripple", "upper", LOOSE_MAX_RIPPLE)


def _bound(axis, epsilon: float) -> dict:
    """The keyword of ``PhaseSolver.solve_from`` that holds the gain at least ``epsilon``."""
    return {"min_ratio": epsilon} if axis.is_ratio else {"bound": axis.bound(epsilon)}


def _multiplier(axis, record) -> float | None:
    """d δ / d (the quantity's bound) at a point: the ratio's own multiplier, or the active
    set's sensitivity of the axis's bound (0 where it is slack)."""
    if axis.is_ratio:
        return record.ratio_multiplier
    return next((a["sensitivity"] for a in record.active if a["name"] == axis.name), 0.0)


def solve_point(problem, count: int, index: int, epsilon: float, start: dict,
                fallbacks: list[dict], seeds: list[dict] = (), also: list[dict] = (),
                tags: dict | None = None, known: list[dict] = (),
                warm: dict | None = None) -> dict:
    """Least ripple subject to ratio >= ε: polished from ``start`` (the chain's previous
    design) and each of ``also`` (further warm starts: a refined point's other neighbour),
    then from each of ``seeds`` (the screening's best basins that reach ε, as secondary
    polishes stopped once they join an optimum already found); then each of ``known``
    (the count's verified ends: ``design``, ``delta`` and ``gain``) and, for a re-solve, its
    start are candidates as they are, verified under the point's bound, so no point ends
    worse than a known design that meets its ε; the best verified design wins
    (:func:`best_candidate`). Only when none is feasible: from each of ``fallbacks``,
    then from the multi-start designs. ``tags`` are added to the record (its round, the point
    a re-solve replaces). ``warm``: the primal-dual optimum that ended on ``start`` (its
    record's ``warm``): ``start``'s polish begins from it where the NLP is the same
    (:meth:`PhaseSolver.solve_from`); the record keeps its own optimum's as ``warm``."""
    point = _Point(problem, count, index, "sweep", epsilon)
    solver = PhaseSolver(problem, count)
    found: list[Candidate] = []
    last, note = None, "no start design assembles"

    def attempt(values, source, secondary=False, warm=None):
        nonlocal last, note
        point.tries += 1
        solver.avoid = [c.outcome.values for c in found if c.feasible] if secondary else []
        try:
            outcome = solver.solve_from(dict(values), secondary=secondary, warm=warm,
                                        **_bound(axis_of(problem), epsilon))
        except (OptDesignError, RuntimeError, ValueError, ArithmeticError) as exc:
            # one start that breaks the evaluator (CasADi raises RuntimeError) is one failed
            # start, not a failed sweep
            note = f"{type(exc).__name__}: {exc}"
            return
        finally:
            solver.avoid = []
        last = outcome.record
        point.iterations += last.iterations
        found.append(Candidate(outcome, source))

    tags = tags or {}
    first = "dominating" if tags.get("replaces") is not None else \
        "chain" if not tags.get("round") else "neighbour"
    for values in [start, *also]:
        if values:                  # a second warm start stops once it joins the first's
            attempt(values, first if values is start else "neighbour", secondary=bool(found),
                    warm=warm if values is start else None)
    for values in seeds:
        if not any(_beside(problem, values, c.outcome.values) for c in found if c.feasible):
            attempt(values, "screening", secondary=bool(found))
    # A known design that meets the bound is a candidate as it is: a polish that ends in a
    # worse local optimum never stands, and a re-solve never ends worse than the design that
    # called for it. An end is verified under the bound only where its record says it would
    # win (its gain reaches ε and its δ beats the polishes'): one exact check, seldom.
    ahead = best_candidate(found)
    wins = [k["design"] for k in known if k.get("design") and
            k["gain"] >= epsilon - 1e-9 * max(1.0, abs(epsilon)) and
            (ahead is None or k["delta"] < ahead.delta * (1 - IMPROVEMENT))]
    as_they_are = [(d, "known design") for d in wins] + \
        ([(start, "dominating")] if tags.get("replaces") is not None and start else [])
    for values, source in as_they_are:
        if not any(c.outcome.values == values for c in found):
            point.tries += 1
            found.append(Candidate(solver.as_it_is(dict(values), **_bound(axis_of(problem),
                                                                          epsilon)), source))
    best = best_candidate(found)
    if best is None:
        def rescue():
            yield from ((dict(s), "other end") for s in fallbacks if s)
            for d in start_designs(problem, count, problem.solver.starts):
                yield dict(d.values), "multistart"

        for values, source in rescue():
            attempt(values, source)
            best = best_candidate(found)
            if best is not None or point.tries >= 2 + len(also) + len(seeds) + \
                    max(1, problem.solver.starts):
                break
    if best is not None:
        rec = best.outcome.record
        mult = _multiplier(axis_of(problem), rec) if rec.ipopt_status == "Solve_Succeeded" \
            else None
        out = point.record("optimal", best.outcome.values, best.outcome.verification, mult,
                           rec.ipopt_status, active=rec.active)
        return out | {"start_from": best.source, "warm": best.outcome.warm} | tags
    # as in solve.driver: infeasible only on IPOPT's word, not for running out of iterations
    status = "infeasible" if last is not None and \
        last.ipopt_status == "Infeasible_Problem_Detected" else "failed"
    return point.record(status, ipopt_status=last.ipopt_status if last else "",
                        note=last.note if last else note) | {"start_from": ""} | tags


#: a seed this close to an optimum already found (share of each free length's box) would join
#: it at once: not polished
BESIDE_SHARE = 0.02


def _beside(problem, a: dict, b: dict) -> bool:
    return all(abs(a[k] - b[k]) <= BESIDE_SHARE * (problem.design[k].upper -
                                                   problem.design[k].lower)
               for k in problem.free_lengths())


@dataclass
class Candidate:
    """One polish of an ε point: its outcome and where it started (``chain``: the chain's
    previous design; ``neighbour``: a refined point's neighbour on the front; ``dominating``:
    the design that dominated the point a re-solve replaces; ``screening``, ``other end``,
    ``multistart``)."""

    outcome: Any
    source: str

    @property
    def feasible(self) -> bool:
        return bool(self.outcome.record.feasible)

    @property
    def delta(self) -> float:
        return float(self.outcome.verification.delta)


#: a later candidate must beat the earlier best δ by this share to win (the chain's own
#: design is kept on a tie: the front stays on one branch where two are equal)
IMPROVEMENT = 1e-6


def best_candidate(candidates: list) -> "Candidate | None":
    """The verified feasible candidate of least exact δ, or None; of candidates within
    :data:`IMPROVEMENT` of each other the first (the chain's) is kept."""
    best = None
    for c in candidates:
        if c.feasible and (best is None or c.delta < best.delta * (1 - IMPROVEMENT)):
            best = c
    return best


def copy_end(end: dict, index: int) -> dict:
    """An end-point record re-keyed as grid point ``index`` (its ε the gain it reaches when
    it was solved without one)."""
    reached = end["gain"] if "gain" in end else end["ratio"]
    return end | {"key": [end["count"], index], "time_s": 0.0, "iterations": 0, "tries": 0,
                  "epsilon": reached if end["epsilon"] is None else end["epsilon"]}


def _quantities(problem, figures) -> dict:
    """The exact quantities of a verified point: a PhaseResult's own, else from the
    verification's evaluation."""
    known = getattr(figures, "quantities", None)
    if known is not None:
        return known
    return design_quantities(problem, getattr(figures, "evaluation", None))


@dataclass(frozen=True)
class _Ver:
    """The exact figures of a PhaseResult, shaped like a Verification."""

    delta: float
    ratio: float
    min_angle_deg: float
    quantities: dict

    @classmethod
    def of(cls, res) -> "_Ver":
        return cls(res.delta, res.ratio, res.min_transmission_angle_deg, res.quantities)

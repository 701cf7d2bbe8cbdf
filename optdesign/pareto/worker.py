"""The units of work of a sweep: one end-point solve or one ε point of one phase count.

These functions run in worker processes (or on Dask workers): they take and return plain data
(the frozen problem and dicts of floats), and each process keeps the NLPs it has built
(:class:`~optdesign.solve.PhaseSolver`) so consecutive points of a chain re-solve the same NLP
with a new ε parameter instead of rebuilding it.
"""
from __future__ import annotations

import hashlib
import pickle
import time
from dataclasses import replace

from ..errors import OptDesignError
from ..solve import PhaseSolver, solve_phase
from ..criteria import LengthConstraint, constraints_of
from ..solve.starts import start_designs

#: the ripple cap of the largest-ratio solve: loose (midrange δ never exceeds 2)
LOOSE_MAX_RIPPLE = 10.0
#: the largest-ratio design is re-solved for least ripple at this fraction below its ratio
END_RATIO_BACKOFF = 1e-7

_SOLVERS: dict = {}


def _solver(problem, count: int) -> PhaseSolver:
    key = (hashlib.sha256(pickle.dumps(problem)).hexdigest(), count)
    if key not in _SOLVERS:
        if len(_SOLVERS) > 8:
            _SOLVERS.clear()
        _SOLVERS[key] = PhaseSolver(problem, count)
    return _SOLVERS[key]


def criteria_columns(problem, values: dict) -> dict:
    """The report columns the problem's criteria give a design (e.g. the four-bar's pin
    radius, as its mechanism computes it under the file's pin layout)."""
    lengths = {k: float(values[k]) for k in problem.model.lengths}
    out = {}
    for c in constraints_of(problem):
        if isinstance(c, LengthConstraint) and c.column:
            out[c.column] = float(c.formula(lengths))
    return out


def _record(problem, count, tag, kind, epsilon, values, ver, status, multiplier, t0,
            iterations, tries, ipopt_status, note="") -> dict:
    feasible = status == "optimal"
    design = {k: float(values[k]) for k in problem.model.lengths} if values else {}
    if design:
        design[problem.model.count_variable] = count
    return {"key": [count, tag], "phases": count, "kind": kind, "epsilon": epsilon,
            "status": status, "feasible": feasible, "design": design,
            "delta": ver.delta if ver is not None and feasible else None,
            "ratio": ver.ratio if ver is not None and feasible else None,
            "min_transmission_angle_deg": ver.min_angle_deg if ver is not None and feasible
            else None,
            **({k: (v if feasible else None) for k, v in
                criteria_columns(problem, values or problem.start_values()).items()}),
            "ratio_multiplier": multiplier, "ipopt_status": ipopt_status,
            "iterations": iterations, "tries": tries, "time_s": time.perf_counter() - t0,
            "note": note}


def solve_end(problem, count: int, kind: str) -> dict:
    """One end of a phase count's front.

    ``least_ripple``: the plain multi-start solve (the ratio bound is the problem's own).
    ``largest_ratio``: maximise the ratio under a loose ripple cap, then re-minimise δ with the
    ratio held at that value (a lexicographic optimum, so the end point is not dominated).
    """
    t0 = time.perf_counter()
    if kind == "least_ripple":
        res = solve_phase(problem, count, solver=_solver(problem, count))
        iterations = res.iterations
        if res.status != "optimal":
            return _record(problem, count, kind, kind, None, None, None, res.status, None, t0,
                           iterations, len(res.starts), "", res.message)
        ver_ok = _Ver(res.delta, res.ratio, res.min_transmission_angle_deg)
        slack = res.ratio - problem.objective.min_ratio > 1e-6
        return _record(problem, count, kind, kind, None, res.design, ver_ok, "optimal",
                       0.0 if slack else None, t0, iterations, len(res.starts),
                       "Solve_Succeeded")
    q = replace(problem, objective=replace(problem.objective, minimize="-ratio",
                                           max_ripple=LOOSE_MAX_RIPPLE))
    res = solve_phase(q, count, solver=_solver(q, count))
    if res.status != "optimal":
        return _record(problem, count, kind, kind, None, None, None, res.status, None, t0,
                       res.iterations, len(res.starts), "", res.message)
    ratio = res.ratio * (1 - END_RATIO_BACKOFF)
    outcome = _solver(problem, count).solve_from(dict(res.design), min_ratio=ratio)
    rec, ver, values = outcome.record, outcome.verification, outcome.values
    iterations = res.iterations + rec.iterations
    if rec.feasible and ver.delta <= res.delta:
        return _record(problem, count, kind, kind, ratio, values, ver, "optimal",
                       rec.ratio_multiplier if rec.ipopt_status == "Solve_Succeeded" else None,
                       t0, iterations, len(res.starts) + 1, rec.ipopt_status)
    return _record(problem, count, kind, kind, None, res.design,
                   _Ver(res.delta, res.ratio, res.min_transmission_angle_deg), "optimal",
                   None, t0, iterations, len(res.starts), "Solve_Succeeded")


def solve_point(problem, count: int, index: int, epsilon: float, start: dict,
                fallbacks: list[dict]) -> dict:
    """Least ripple subject to ratio >= ε, warm-started from ``start`` (the chain's previous
    design); on failure from each of ``fallbacks``, then from the multi-start designs."""
    t0 = time.perf_counter()
    solver = _solver(problem, count)
    iterations, tries, last, note = 0, 0, None, "no start design assembles"

    def attempts():
        yield from (dict(s) for s in [start, *fallbacks] if s)
        for d in start_designs(problem, count, problem.solver.starts):
            yield dict(d.values)

    for values in attempts():
        try:
            outcome = solver.solve_from(values, min_ratio=epsilon)
            rec, ver, values = outcome.record, outcome.verification, outcome.values
        except (OptDesignError, RuntimeError, ValueError, ArithmeticError) as exc:
            # one start that breaks the evaluator (CasADi raises RuntimeError) is one failed
            # start, not a failed sweep
            tries += 1
            note = f"{type(exc).__name__}: {exc}"
            continue
        iterations += rec.iterations
        tries += 1
        last = rec
        if rec.feasible:
            mult = rec.ratio_multiplier if rec.ipopt_status == "Solve_Succeeded" else None
            return _record(problem, count, index, "sweep", epsilon, values, ver, "optimal",
                           mult, t0, iterations, tries, rec.ipopt_status)
        if tries >= 2 + max(1, problem.solver.starts):
            break
    # as in solve.driver: infeasible only on IPOPT's word, not for running out of iterations
    status = "infeasible" if last is not None and \
        last.ipopt_status == "Infeasible_Problem_Detected" else "failed"
    return _record(problem, count, index, "sweep", epsilon, None, None, status, None, t0,
                   iterations, tries, last.ipopt_status if last else "",
                   last.note if last else note)


def copy_end(end: dict, index: int) -> dict:
    """An end-point record re-keyed as grid point ``index``."""
    return end | {"key": [end["phases"], index], "time_s": 0.0, "iterations": 0, "tries": 0,
                  "epsilon": end["ratio"] if end["epsilon"] is None else end["epsilon"]}


class _Ver:
    """The three figures of a PhaseResult, shaped like a Verification for ``_record``."""

    def __init__(self, delta, ratio, angle):
        self.delta, self.ratio, self.min_angle_deg = delta, ratio, angle


"""Polishes on a box of decades: where no polish of a count converged, the polishes the
secondary budget stopped are run again to their end (``Polishing.rescue``) and a basin
beside a known design is polished in full; in a box of decades every IPOPT run has
``WIDE_ITERATIONS`` times ``solver.max_iter`` iterations (``iterations_of``) and an L-BFGS
verdict of local infeasibility is retried with the exact Hessian.

Found by ``benchmarks/solve_denser.py``: on the oracle's four-bar boxes of two to five
decades, 14 of 96 counts ended `optimal` at a design where a polish that ran out of
iterations stopped, while a basin polished with more iterations (or a budget-stopped basin
run to its end) reached half the ripple."""
from __future__ import annotations

import dataclasses
from pathlib import Path
from types import SimpleNamespace

import pytest

from optdesign.problem.loader import load_problem
from optdesign.solver.phase_solver import EXHAUSTED, Outcome, PhaseSolver, _Run
from optdesign.solver.polishing import Polishing
from optdesign.solver.result import PhaseResult, StartRecord
from optdesign.solver.screening import WIDE_ITERATIONS, iterations_of

ROOT = Path(__file__).resolve().parents[2]
DISC = ROOT / "problems" / "sharkov2022_disc.yaml"


def _outcome(start: dict, status: str, feasible: bool, key: float, end: dict) -> Outcome:
    record = StartRecord(start=dict(start), ipopt_status=status, iterations=50, time_s=0.0,
                         feasible=feasible, delta=key)
    ver = SimpleNamespace(feasible=feasible, key=key, delta=key)
    return Outcome(record, ver, dict(end), key)


class _Scripted:
    """A solver whose polishes end as ``script`` says, by start and by ``secondary``."""

    def __init__(self, script):
        self.script, self.calls, self.avoid = script, [], []

    def solve_from(self, values, ver=None, secondary=False):
        self.calls.append((values["l0"], secondary))
        return self.script(values, secondary)


def _starts(problem, count, n):
    base = problem.start_values() | {problem.model.count_variable: count}
    return [base | {"l0": base["l0"] + i} for i in range(n)]


def test_budget_stopped_polishes_run_to_their_end_where_none_converged():
    problem = load_problem(DISC)
    starts = _starts(problem, 6, 3)

    def script(values, secondary):
        if secondary:
            return _outcome(values, EXHAUSTED, False, 0.3, values)
        if values["l0"] == starts[2]["l0"]:      # the third converges when run to its end
            return _outcome(values, "Solve_Succeeded", True, 0.1, values)
        return _outcome(values, "Maximum_Iterations_Exceeded", False, 0.5, values)

    solver = _Scripted(script)
    work = Polishing(problem, 6, solver, PhaseResult(6, "failed"))
    for values, secondary in zip(starts, (False, True, True)):
        work.record(solver.solve_from(values, secondary=secondary))
    assert not work.converged()
    solver.calls.clear()
    work.rescue()
    # the stopped polishes again, without the budget, until one converges
    assert solver.calls == [(starts[1]["l0"], False), (starts[2]["l0"], False)]
    assert work.converged() and work.best.verification.key == 0.1


def test_the_rescue_keeps_to_the_count_s_polishes():
    problem = load_problem(DISC)
    problem = dataclasses.replace(problem, solver=dataclasses.replace(problem.solver, starts=3))
    starts = _starts(problem, 6, 3)
    solver = _Scripted(lambda v, s: _outcome(v, EXHAUSTED if s else "Solve_Succeeded",
                                             not s, 0.1, v))
    work = Polishing(problem, 6, solver, PhaseResult(6, "failed"))
    for values in starts:
        work.record(_outcome(values, EXHAUSTED, False, 0.3, values))
    work.rescue()                   # three polishes made: solver.starts
    assert solver.calls == []


def test_no_rescue_beside_a_converged_optimum():
    problem = load_problem(DISC)
    starts = _starts(problem, 6, 2)
    solver = _Scripted(lambda v, s: _outcome(v, "Solve_Succeeded", True, 0.1, v))
    work = Polishing(problem, 6, solver, PhaseResult(6, "failed"))
    work.record(_outcome(starts[0], "Solve_Succeeded", True, 0.1, starts[0]))
    work.record(_outcome(starts[1], EXHAUSTED, False, 0.3, starts[1]))
    work.rescue()
    assert solver.calls == []


def _with_range(problem, name, lower, upper):
    value = problem.design[name]
    return dataclasses.replace(problem, design=problem.design | {
        name: dataclasses.replace(value, lower=lower, upper=upper)})


def test_a_box_of_decades_gives_ipopt_more_iterations():
    problem = load_problem(DISC)
    assert iterations_of(problem) == problem.solver.max_iter
    free = problem.free_lengths()[0]
    lower = problem.design[free].lower
    assert iterations_of(_with_range(problem, free, lower, 99 * lower)) == \
        problem.solver.max_iter
    assert iterations_of(_with_range(problem, free, lower, 100 * lower)) == \
        WIDE_ITERATIONS * problem.solver.max_iter


def test_a_box_of_four_decades_reaches_the_basin_its_polishes_used_to_stop_short_of():
    """The oracle's draw 54 (``benchmarks/solve_denser.py``): the disc converter of six phases
    in a box of four decades. Its polishes used to run out of 100 iterations or stop at the
    budget, and the count ended `optimal` at δ 0.1406, where one of them had stopped; the
    basin a budget-stopped polish was on holds δ 0.0647."""
    from optdesign.problem.loader import problem_from_dict
    from optdesign.solver import solve

    wide = {"lower": 0.33946225248946815, "upper": 8313.528292695066}
    problem = problem_from_dict({
        "name": "four_decades", "mechanism": "fourbar_converter", "input_speed": 97.0,
        "stroke": "reverse",
        "design": {"l0": wide, "l1": 20, "l2": wide,
                   "l2_prime": {"lower": 0.16102108462768244, "upper": 3943.4527195751057},
                   "l3": {"lower": 0.09296556655499798, "upper": 2276.7534891832493},
                   "phases": 6},
        "constraints": {"min_transmission_angle_deg": 40, "min_pin_radius": 25.0},
        "objective": {"minimize": "ripple"}}, where="four_decades.yaml")
    result = solve(problem)
    assert result.status == "optimal"
    assert result.delta < 0.07
    assert any(s.ipopt_status == "Solve_Succeeded" and s.feasible
               for s in result.per_phase[0].starts)


def test_a_basin_beside_a_known_design_is_polished_in_full():
    """The secondary budget is for a basin beside a converged optimum: beside a known design
    (where a polish that ran out of iterations stopped) the next basin runs to its end."""
    problem = load_problem(DISC)
    starts = _starts(problem, 6, 3)
    solver = _Scripted(lambda v, s: _outcome(v, "Solve_Succeeded", True, 0.2, v))
    work = Polishing(problem, 6, solver, PhaseResult(6, "failed"))
    work.consider(_outcome(starts[0], "Known_Design_As_It_Is", True, 0.3, starts[0]))
    assert work.best is not None and not work.converged()
    work.polish(starts[1])
    work.polish(starts[2])
    assert solver.calls == [(starts[1]["l0"], False), (starts[2]["l0"], True)]


@pytest.mark.parametrize("decades", [False, True])
def test_a_quasi_newton_verdict_of_infeasibility_is_retried_in_a_box_of_decades(monkeypatch,
                                                                                  decades):
    """Given three times the iterations in a box of decades, L-BFGS can wander far enough to
    call a basin infeasible that the exact Hessian converges in (the oracle's draw 195, a
    slotted lever in a box of five decades): there, and only there, the run is retried."""
    problem = load_problem(DISC)
    if decades:
        free = problem.free_lengths()[0]
        lower = problem.design[free].lower
        problem = _with_range(problem, free, lower, 1000 * lower)
    count = 6
    start = problem.start_values() | {problem.model.count_variable: count}
    hessians = []

    def infeasible(self, problem, ver, tightening, hessian, budget=None, warm=None):
        hessians.append(hessian)
        return _Run(status="Infeasible_Problem_Detected", iterations=7, lengths={},
                    surrogate=0.5, multiplier=0.0, at_window=False, binding="", active=[])

    monkeypatch.setattr(PhaseSolver, "_ipopt", infeasible)
    PhaseSolver(problem, count).solve_from(dict(start))
    assert hessians == (["limited-memory", "exact"] if decades else ["limited-memory"])

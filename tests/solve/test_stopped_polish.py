"""A polish stopped before its end (stalled, out of its secondary budget, joined to a known
basin) keeps its start's exact check: nothing reads a check of where it stopped, so none is
made (optdesign/solver/phase_solver.py, ``PhaseSolver.solve_from``)."""
from __future__ import annotations

from pathlib import Path

import pytest

from optdesign.problem.loader import load_problem
from optdesign.solver import phase_solver
from optdesign.solver.phase_solver import EXHAUSTED, JOINED, STALLED, PhaseSolver, _Run

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("status", [STALLED, EXHAUSTED, JOINED])
def test_a_stopped_polish_is_checked_at_its_start_only(monkeypatch, status):
    problem = load_problem(ROOT / "problems" / "sharkov2022_disc.yaml")
    count = 6
    start = problem.start_values() | {problem.model.count_variable: count}
    moved = {k: start[k] * 1.01 for k in problem.free_lengths()}
    checked = []
    real = phase_solver.verify

    def counted(p, values, *args, **kwargs):
        checked.append(dict(values))
        return real(p, values, *args, **kwargs)

    def stopped(self, *args, **kwargs):
        return _Run(status=status, iterations=7, lengths=moved, surrogate=0.5,
                    multiplier=0.0, at_window=False, binding="", active=[])

    monkeypatch.setattr(phase_solver, "verify", counted)
    monkeypatch.setattr(PhaseSolver, "_ipopt", stopped)
    outcome = PhaseSolver(problem, count).solve_from(dict(start), secondary=True)
    assert checked == [start]                   # the start's check, not the stopped end's
    assert outcome.record.ipopt_status == status and not outcome.record.feasible
    assert outcome.record.iterations == 7
    assert outcome.values == start              # a stopped polish ends where it began

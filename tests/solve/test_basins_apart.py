"""A phase count whose best basins end apart is polished further (optdesign/solver/polishing.py,
``Polishing.apart``): the disc kept, reverse stroke, six phases. The screening ranks a basin
by its seed's sampled δ, and the basin of the optimum (l3 ≈ 27 mm on the transmission-angle
bound, δ = 0.14165) ranks fourth; the two best basins give δ = 0.14634 and a polish that does
not converge in the secondary budget. About 4 s."""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest

from optdesign.problem.loader import load_problem
from optdesign.solver import phase_solver, polishing, solve, verify

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def six_phases():
    problem = load_problem(ROOT / "problems" / "pareto_disc_three_counts.yaml")
    design = dict(problem.design)
    design["phases"] = replace(design["phases"], choices=(6,))
    return replace(problem, design=design)


def test_the_best_basin_ranked_fourth_is_polished(six_phases):
    result = solve(six_phases)
    assert result.status == "optimal"
    assert result.delta == pytest.approx(0.141649, abs=2e-6)
    assert result.design["l3"] == pytest.approx(26.86, abs=0.05)
    assert verify(six_phases, result.design).feasible
    phase = result.best_phase()
    assert phase.screening["polished"] > six_phases.solver.basins


def test_without_the_rule_the_solve_stops_in_the_worse_basin(six_phases, monkeypatch):
    """The case exercises the rule: polishing only the two best-ranked basins ends worse."""
    monkeypatch.setattr(polishing.Polishing, "apart", lambda self: False)
    result = solve(six_phases)
    assert result.delta > 0.1416 + 1e-3


def test_on_one_worker_the_best_basins_are_polished_as_on_two(six_phases):
    """The best basins are polished as if at once, each knowing no optimum the others found:
    the same polishes on one worker (an atlas's cells, a front's ends) as on two, and the
    same answer. (One worker used to polish the second basin knowing the first's optimum:
    it stopped as it passed near it, a stop that counts as reaching none, and two more
    basins followed; polished beside the first, it exhausts its budget.)"""
    polishes = {}
    for workers in (1, 2):
        problem = replace(six_phases, solver=replace(six_phases.solver, workers=workers))
        result = solve(problem)
        assert result.delta == pytest.approx(0.141649, abs=2e-6)
        polishes[workers] = [(s.ipopt_status, s.iterations, s.delta)
                             for s in result.best_phase().starts]
    assert polishes[1] == polishes[2]
    assert polishes[1][1][0] == phase_solver.EXHAUSTED


def test_a_second_basin_that_stalls_infeasible_does_not_call_for_more():
    """The disc problem at four phases: the second basin's polish is still infeasible after
    its first 30 iterations (``Stalled_Infeasible``), which says nothing of where that basin
    leads; the count is not polished further (two more basins were, which joined the first's
    optimum and stalled again), and the optimum is the same."""
    problem = load_problem(ROOT / "problems" / "sharkov2022_disc.yaml")
    design = dict(problem.design)
    design["phases"] = replace(design["phases"], value=4.0)
    problem = replace(problem, design=design)
    result = solve(problem)
    assert result.status == "optimal"
    assert result.delta == pytest.approx(0.252056, abs=2e-6)
    starts = result.best_phase().starts
    assert [s.ipopt_status for s in starts[:2]] == ["Solve_Succeeded", phase_solver.STALLED]
    assert result.best_phase().screening["polished"] == 2

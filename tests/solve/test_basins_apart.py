"""A phase count whose best basins end apart is polished further (optdesign/solver/driver.py,
``_Polishing.apart``): the disc kept, reverse stroke, six phases. The screening ranks a basin
by its seed's sampled δ, and the basin of the optimum (l3 ≈ 27 mm on the transmission-angle
bound, δ = 0.14165) ranks fourth; the two best basins give δ = 0.14634 and a polish that does
not converge in the secondary budget. About 4 s."""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest

from optdesign.problem.loader import load_problem
from optdesign.solver import driver, solve, verify

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
    monkeypatch.setattr(driver._Polishing, "apart", lambda self: False)
    result = solve(six_phases)
    assert result.delta > 0.1416 + 1e-3


def _record(status: str, feasible: bool):
    from optdesign.solver.result import StartRecord
    return StartRecord(start={}, ipopt_status=status, iterations=10, time_s=0.0,
                       feasible=feasible, delta=0.2 if feasible else None)


@pytest.mark.parametrize("second, apart", [
    ((driver.JOINED, False), False),              # reached the first's optimum
    ((driver.STALLED, False), True),              # reached none
    ((driver.EXHAUSTED, False), True),
    (("Infeasible_Problem_Detected", False), True),
    (("Solve_Succeeded", False), True),           # converged, but the exact check rejects it
    (("Solve_Succeeded", True), False),           # the same optimum (one in ``optima``)
])
def test_a_polish_that_joined_a_known_optimum_is_not_apart(six_phases, second, apart):
    """``apart``: more than one optimum, or a polish that reached none. A polish stopped as
    it entered a known optimum's basin (its record is not feasible: it ended at its start)
    reached that optimum; it counted as apart, and so a second basin that joined the first
    sent every solve on one worker through two more basins."""
    from optdesign.solver.result import PhaseResult

    result = PhaseResult(6, "failed")
    result.starts = [_record("Solve_Succeeded", True), _record(*second)]
    work = driver._Polishing(six_phases, 6, None, result)
    work.optima = ["the first's optimum"]
    assert work.apart() is apart


def test_on_one_worker_a_basin_that_joins_ends_the_polishes():
    """The shipped disc problem on one worker: the second basin joins the first's optimum,
    and no further basin is polished; the answer is the one two workers find (where the two
    best basins are polished at once, and the second converges to the same design)."""
    problem = load_problem(ROOT / "problems" / "sharkov2022_disc.yaml")
    alone = solve(replace(problem, solver=replace(problem.solver, workers=1)))
    phase = alone.best_phase()
    assert [s.ipopt_status for s in phase.starts][:2] == ["Solve_Succeeded", driver.JOINED]
    assert phase.screening["polished"] == 2
    both = solve(replace(problem, solver=replace(problem.solver, workers=2)))
    assert alone.status == both.status == "optimal"
    assert alone.delta == pytest.approx(both.delta, rel=1e-11)
    for k, v in both.design.items():
        assert alone.design[k] == pytest.approx(v, rel=1e-8), k

"""The file's own design, a candidate as it is: checked exactly unless a verified optimum beats
it for certain (its sampled floor of δ, optdesign.solver.screening.ripple_floor, lies above
the optimum's δ), so the answer is never worse than it and no check is made that cannot win.

The floor is a claim: set here against the exact δ of a sample of each mechanism's box, at
every admissible count, for every stroke."""
import math

import numpy as np
import pytest

from optdesign.problem.loader import problem_from_dict
from optdesign.solver import phase_solver, solve, verify
from optdesign.solver.screening import FLOOR_MARGIN, ripple_floor
from tests.conftest import ROOT, file_data

VERGOV = ROOT / "problems" / "vergov_solve.yaml"


def _checked_as_they_are(monkeypatch) -> list[dict]:
    """The designs the solve checks as they are, in order (the file's own among them)."""
    checked = []
    original = phase_solver.PhaseSolver.as_it_is

    def recorded(self, values, *args, **kwargs):
        checked.append(dict(values))
        return original(self, values, *args, **kwargs)

    monkeypatch.setattr(phase_solver.PhaseSolver, "as_it_is", recorded)
    return checked


def _given(problem, count: int) -> dict:
    return problem.start_values() | {problem.model.count_variable: count}


def test_a_design_the_optimum_beats_for_certain_is_not_checked(monkeypatch):
    """Vergov's variator: the file's XD = 292 has a sampled floor of δ above the optimum of
    either count (0.312 against 0.276 at 3 sections, 0.290 against 0.199 at 5): its exact
    check could not win, and is not made; the answer is the one the check would leave."""
    problem = problem_from_dict(file_data(VERGOV))
    checked = _checked_as_they_are(monkeypatch)
    result = solve(problem)
    assert result.status == "optimal" and result.design["sections"] == 5
    for phase in result.per_phase:
        given = _given(problem, phase.count)
        assert given not in checked
        assert ripple_floor(problem, phase.count, given) > phase.delta
        # what the check would have said: a poorer design than the optimum
        assert verify(problem, given).delta > phase.delta


def test_a_design_that_may_win_is_checked_and_is_the_answer_when_it_wins(monkeypatch):
    """The file's design set at the optimum itself: its floor lies below the optimum's δ, so
    it is checked, as it is."""
    best = solve(problem_from_dict(file_data(VERGOV))).design
    data = file_data(VERGOV)
    data["design"]["XD"]["initial"] = best["XD"]
    problem = problem_from_dict(data)
    checked = _checked_as_they_are(monkeypatch)
    result = solve(problem)
    assert _given(problem, best["sections"]) in checked
    assert result.delta <= verify(problem, _given(problem, best["sections"])).delta


def _box_sample(problem, rng, n: int) -> list[dict]:
    free = problem.free_lengths()
    out = []
    for _ in range(n):
        values = problem.start_values()
        for k in free:
            lo, hi = problem.design[k].lower, problem.design[k].upper
            values[k] = float(math.exp(rng.uniform(math.log(lo), math.log(hi))))
        out.append(values)
    return out


@pytest.mark.parametrize("name, stroke", [
    ("sharkov2022_disc", "forward"), ("sharkov2022_disc", "reverse"),
    ("vergov_solve", "both"), ("vergov_solve", "forward"),
    ("pulse_reducer_solve", "forward"), ("free_design", "reverse")])
def test_the_floor_never_lies_above_the_exact_ripple_on_a_sample_of_the_box(name, stroke):
    """Every design of a random sample of the box that assembles, at every admissible count:
    floor <= exact worst δ (within the margin the two computations' roundings are given)."""
    data = file_data(ROOT / "problems" / f"{name}.yaml", stroke=stroke)
    problem = problem_from_dict(data, where=f"{name}.yaml")
    rng = np.random.default_rng(7)
    compared = 0
    for count in problem.counts()[:3]:
        for values in _box_sample(problem, rng, 60 // len(problem.counts()[:3])):
            values[problem.model.count_variable] = count
            floor = ripple_floor(problem, count, values)
            ver = verify(problem, values)
            if not ver.evaluation.assembles or math.isnan(floor):
                continue
            compared += 1
            assert floor <= ver.delta * (1 + FLOOR_MARGIN), (count, values)
    assert compared >= 6

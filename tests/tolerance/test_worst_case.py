"""The worst case over the tolerance box: a bound on every sampled part, as good as a dense
grid, exact, and found inside the box when it lies there."""
import itertools

import numpy as np
import pytest

import optdesign.tolerance.worst_case as wc
from optdesign.problem.loader import problem_from_dict
from optdesign.tolerance.exact_part import exact_part
from optdesign.tolerance.montecarlo import monte_carlo
from optdesign.tolerance.parts import box_of
from optdesign.tolerance.sampled import calibrated, sampled_parts
from optdesign.tolerance.worst_case import worst_case
from tests.tolerance.conftest import paper

#: two lengths toleranced (the others exact), n = 3: a case small enough for a dense grid
TWO = {"l2_prime": 0.5, "l3": 0.5}


@pytest.fixture(scope="module")
def two_lengths():
    problem = problem_from_dict(paper(design={**paper()["design"], "phases": 3},
                                      tolerances={"default": 0, "lengths": TWO}))
    return problem, worst_case(problem, None, TWO), \
        worst_case(problem, None, TWO, quantity="transmission_angle")


def test_the_worst_case_bounds_a_monte_carlo_of_a_hundred_thousand_parts(two_lengths):
    problem, worst, least = two_lengths
    frame = monte_carlo(problem, samples=100_000, seed=5)
    assert frame["assembles"].all()
    assert worst.value >= frame["delta"].max()
    assert least.value <= frame["mu_min_deg"].min()
    assert worst.value > worst.nominal and least.value < least.nominal
    # and the figures are exact: the evaluator gives them again at the reported parts
    assert exact_part(problem, worst.lengths)["delta"] == worst.value
    assert exact_part(problem, least.lengths)["mu_min_deg"] == least.value
    assert set(worst.deviation) == set(problem.model.lengths)
    assert worst.deviation["l0"] == 0 and abs(worst.deviation["l3"]) <= 0.5
    assert 0 < worst.evaluations < 200


def test_the_worst_case_matches_a_dense_grid(two_lengths):
    """81 × 81 parts on a fine crank grid (256 samples, 1e-9 from the exact evaluator), the
    grid's best part measured exactly: the worst case is within 1e-6 of it, and not below."""
    problem, worst, least = two_lengths
    box = box_of(problem, None, TWO)
    axis = np.linspace(-1, 1, 81)
    offsets = np.zeros((axis.size ** 2, len(box.names)))
    pairs = np.array(list(itertools.product(axis, axis)))
    offsets[:, box.names.index("l2_prime")] = 0.5 * pairs[:, 0]
    offsets[:, box.names.index("l3")] = 0.5 * pairs[:, 1]
    nominal = exact_part(problem, box.values)
    raw = sampled_parts(problem, 3, box.nominal + offsets, samples=256)
    grid = calibrated(raw, sampled_parts(problem, 3, box.nominal[None, :], samples=256),
                      nominal)
    for key, found, sign in (("delta", worst, 1), ("mu_min_deg", least, -1)):
        best = np.argmax(sign * grid[key])
        exact = exact_part(problem, box.part(offsets[best]))[key]
        assert sign * (found.value - exact) >= -1e-12
        assert abs(found.value - exact) <= 1e-6
        assert abs(grid[key][best] - exact) <= 1e-8         # the grid was exact enough


def test_an_interior_worst_point_is_found(monkeypatch, paper_problem):
    """δ replaced by a smooth function whose maximum lies inside the box (and on an edge of
    it in l1): the search reports it to 1e-6, not a corner."""
    names = paper_problem.model.lengths
    centre = {"l0": 0.3, "l1": 2.0, "l2": -0.4, "l2_prime": 0.1, "l3": -0.7}   # units of ±t

    def surface(u):
        return 1.0 - sum((u[..., i] - centre[k]) ** 2 for i, k in enumerate(names))

    def fake_exact(problem, values):
        u = np.array([(values[k] - paper_problem.start_values()[k]) / 0.05 for k in names])
        return {"assembles": True, "delta": float(surface(u)), "mu_min_deg": 50.0,
                "ratio": 0.3, "delta_per_e": [float(surface(u))]}

    def fake_offsets(problem, box, offsets, nominal=None, memo=None):
        u = offsets / 0.05
        return {"delta": surface(u), "ratio": np.full(len(u), 0.3),
                "mu_min_deg": np.full(len(u), 50.0), "assembles": np.ones(len(u), bool)}, \
            nominal

    monkeypatch.setattr(wc, "exact_part", fake_exact)
    monkeypatch.setattr(wc, "evaluate_offsets", fake_offsets)
    found = worst_case(paper_problem, None, paper_problem.sections["tolerances"])
    best = 1.0 - (2.0 - 1.0) ** 2                   # l1 held at its face, the rest at centre
    assert found.value == pytest.approx(best, abs=1e-6)
    assert not found.on_corner
    for k in names:
        want = 0.05 * min(centre[k], 1.0)
        assert found.deviation[k] == pytest.approx(want, abs=1e-5), k


def test_a_box_with_parts_that_fold_has_no_bound():
    """l0 ± 30 mm reaches designs that do not assemble: δ is unbounded there."""
    problem = problem_from_dict(paper(tolerances={"default": 0, "lengths": {"l0": 30}}))
    found = worst_case(problem, None, problem.sections["tolerances"])
    assert not found.assembles and found.value == float("inf")
    assert not exact_part(problem, found.lengths)["assembles"]
    angle = worst_case(problem, None, {"l0": 30}, quantity="transmission_angle")
    assert not angle.assembles and angle.value == 0.0


def test_no_tolerance_is_the_nominal(paper_problem):
    found = worst_case(paper_problem, {"l3": 57.0}, {})
    assert found.value == exact_part(paper_problem, {"l3": 57.0})["delta"]
    assert found.lengths["l3"] == 57.0 and found.evaluations == 1

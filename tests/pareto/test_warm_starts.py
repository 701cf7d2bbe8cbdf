"""A front's point polished from its neighbour's primal-dual optimum: fewer iterations, the
same optimum as a cold polish, taken only on the NLP it was found on, and kept in the journal
alone (docs/pareto.md, "Warm starts")."""
import json

import pytest

from optdesign.problem.loader import problem_from_dict
from optdesign.solver import PhaseSolver

from .conftest import small

#: two neighbouring ε of the small front (its ratio spans 0.833-0.848)
EPS_A, EPS_B = 0.838, 0.840


@pytest.fixture(scope="module")
def neighbour():
    """(problem, the polish at EPS_A from the file's start)."""
    problem = problem_from_dict(small(), where="small.yaml")
    start = problem.start_values() | {problem.model.count_variable: 4}
    first = PhaseSolver(problem, 4).solve_from(start, min_ratio=EPS_A)
    assert first.record.feasible and first.warm is not None
    return problem, first


def test_a_warm_start_takes_fewer_iterations_to_the_same_optimum(neighbour):
    problem, first = neighbour
    cold = PhaseSolver(problem, 4).solve_from(dict(first.values), min_ratio=EPS_B)
    warm = PhaseSolver(problem, 4).solve_from(dict(first.values), min_ratio=EPS_B,
                                               warm=first.warm)
    assert cold.record.feasible and warm.record.feasible
    assert warm.record.iterations < cold.record.iterations
    assert warm.verification.delta == pytest.approx(cold.verification.delta, rel=1e-9)
    assert warm.verification.ratio >= EPS_B - 1e-9         # the bound, to its tolerance
    # the warm optimum is itself a start for the next neighbour
    assert warm.warm is not None and warm.warm["signature"] == first.warm["signature"]


def test_a_primal_dual_found_on_another_nlp_is_not_taken(neighbour):
    problem, first = neighbour
    cold = PhaseSolver(problem, 4).solve_from(dict(first.values), min_ratio=EPS_B)
    foreign = first.warm | {"signature": "another nlp"}
    ignored = PhaseSolver(problem, 4).solve_from(dict(first.values), min_ratio=EPS_B,
                                                  warm=foreign)
    assert ignored.record.iterations == cold.record.iterations
    assert ignored.verification.delta == cold.verification.delta


def test_the_journal_keeps_each_points_optimum_and_the_front_files_do_not(small_front):
    result, out = small_front
    journal = [json.loads(line) for line in (out / "points.jsonl").read_text().splitlines()]
    feasible = [r for r in journal[1:] if r.get("feasible") and r["kind"] == "sweep"]
    assert feasible and all(r["warm"] and len(r["warm"]["x"]) > 0 for r in feasible)
    # a chain's points after its first start from their predecessor's optimum
    assert sum(r["start_from"] == "chain" for r in feasible) >= 2
    data = json.loads((out / "pareto.json").read_text())
    assert all("warm" not in e for e in data["ends"])
    assert all("warm" not in p for p in data["points"])
    assert "warm" not in (out / "pareto.csv").read_text().splitlines()[0].split(",")


def test_warm_up_compiles_the_exact_hessian_of_a_file_with_a_pareto_section():
    from optdesign.commands.warmup import hessians_of

    front = problem_from_dict(small(), where="small.yaml")
    assert hessians_of(front) == ["limited-memory", "exact"]
    plain = {k: v for k, v in small().items() if k != "pareto"}
    assert hessians_of(problem_from_dict(plain, where="plain.yaml")) == ["limited-memory"]
    exact = small() | {"solver": {"starts": 2, "hessian": "exact"}}
    assert hessians_of(problem_from_dict(exact, where="exact.yaml")) == ["exact"]

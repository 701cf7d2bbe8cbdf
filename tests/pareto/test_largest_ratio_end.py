"""The largest-ratio end's first solve, the gain maximised, runs on the exact Hessian whatever
``solver.hessian`` says, and ``optdesign warm-up`` compiles its NLP (docs/pareto.md, "What
the sweep does")."""
import pytest

from optdesign.fronts import worker
from optdesign.problem.loader import problem_from_dict

from .conftest import small


def test_the_largest_ratio_is_maximised_on_the_exact_hessian_under_the_loose_ripple_cap():
    problem = problem_from_dict(small(), where="small.yaml")
    assert problem.solver.hessian == "limited-memory"
    ends = worker.largest_gain_problem(problem)
    assert ends.solver.hessian == "exact"
    assert ends.objective.minimize == "-ratio"
    assert ends.solver.starts == problem.solver.starts       # the rest of the settings kept
    cap = [b for b in ends.constraints.bounds if b.name == "ripple"]
    assert cap and cap[0].upper == worker.LOOSE_MAX_RIPPLE


def test_the_largest_ratio_end_reaches_the_ratio_the_limited_memory_solve_reaches():
    """The exact Hessian's maximum is the limited-memory solve's (the same basin; its
    re-minimised δ there the same to the lexicographic back-off's effect)."""
    from dataclasses import replace

    from optdesign.solver import PhaseSolver, solve_phase

    problem = problem_from_dict(small(), where="small.yaml")
    end = worker.solve_end(problem, 4, "largest_ratio")
    assert end["status"] == "optimal"
    old = replace(worker.largest_gain_problem(problem), solver=problem.solver)
    res = solve_phase(old, 4, solver=PhaseSolver(old, 4))
    assert res.status == "optimal"
    assert end["ratio"] >= res.ratio * (1 - 2 * worker.END_RATIO_BACKOFF)


def test_warm_up_compiles_each_swept_counts_largest_ratio_end():
    from optdesign.commands.warmup import _recipes, end_nlps_of, nlps_to_compile

    front = problem_from_dict(small(counts=[4]), where="small.yaml")
    ends = end_nlps_of(front)
    assert [nlp.count for nlp in ends] == [4]
    assert ends[0].problem.objective.minimize == "-ratio"
    labels = [label for label, _ in _recipes(front, nlps_to_compile(front))]
    assert labels == ["phases = 4", "phases = 4 (exact Hessian)",
                      "phases = 4 (largest-ratio end) (exact Hessian)"]
    plain = {k: v for k, v in small().items() if k != "pareto"}
    assert end_nlps_of(problem_from_dict(plain, where="plain.yaml")) == []

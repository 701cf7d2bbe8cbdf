"""The problem apart from the method: ``load_options``, ``problem.method``,
``problem.with_options`` and the ``options=`` of ``solve`` and ``pareto``, every option read by
the loader's rules."""
import pytest
import yaml

from optdesign import Options, load_options, load_problem, pareto, solve
from optdesign.errors import ProblemError
from tests.conftest import ROOT

DISC = ROOT / "problems" / "sharkov2022_disc.yaml"
LEVER = ROOT / "problems" / "vergov_solve.yaml"


def test_a_file_s_method_is_its_solver_and_pareto_settings():
    options = load_options(DISC)
    assert isinstance(options, Options) and options == load_problem(DISC).method
    assert options.solver.starts == load_problem(DISC).solver.starts and options.pareto is None
    front = load_options(ROOT / "problems" / "pareto_fourbar.yaml")
    assert front.pareto is not None and front.pareto.points > 0


def test_options_given_apart_replace_only_what_they_name():
    problem = load_problem(DISC)
    other = problem.with_options({"solver": {"starts": 2}})
    assert other.solver.starts == 2 and other.solver.screen == problem.solver.screen
    assert other.design == problem.design and other.constraints == problem.constraints
    assert problem.with_options(Options()).solver == Options().solver


@pytest.mark.parametrize("options, error, message", [
    ({"solver": {"startz": 2}}, ProblemError, r"options: solver\.startz is not a known key"),
    ({"solver": {"starts": 0}}, ProblemError, r"options: solver\.starts must be at least 1"),
    ({"pareto": {"counts": [5]}}, ProblemError, r"pareto\.counts \[5\] not admissible"),
    ({"design": {}}, ProblemError, r"options: design is not a known key"),
    (3, TypeError, r"options are an Options or a mapping"),
    (Options(solver={"starts": 2}), TypeError, r"Options\.solver is a SolverSettings"),
    (Options(pareto={"points": 3}), TypeError, r"Options\.pareto is a ParetoSection"),
])
def test_bad_options_are_named_in_one_line(options, error, message):
    with pytest.raises(error, match=message) as caught:
        solve(DISC, options=options)
    assert "\n" not in str(caught.value)


def test_solve_and_pareto_take_options():
    result = solve(LEVER, options={"solver": {"screen": 64}})
    assert result.status == "optimal"
    # the file screens 512 designs per count (the default): these options screen 64 (and
    # the file's own design, and a design carried from the other count)
    assert all(64 <= p.screening["designs"] <= 66 for p in result.per_phase)
    data = yaml.safe_load(LEVER.read_text())
    data["design"]["sections"] = 3
    front = pareto(data, options={"pareto": {"points": 3, "refine": {"enabled": False}}})
    assert (front.points["round"] == 0).sum() <= 3 and front.indicators["n_points"] >= 1

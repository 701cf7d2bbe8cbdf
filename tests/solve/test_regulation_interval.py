"""The whole regulation range: ``regulation: {eccentricity: {lower, upper}}`` holds δ, the ripple
cap and the transmission angle at every e of the interval (docs/formulation.md, "The whole
regulation range")."""
import copy
import json

import numpy as np
import pytest

from optdesign.evaluation.design import Design
from optdesign.errors import ProblemError
from optdesign.problem.loader import problem_from_dict
from optdesign.evaluation.regulation import _AtEccentricity, worst_over_range
from optdesign.solver import PhaseSolver, solve, solve_phase
from optdesign.solver.nlp import PhaseNLP
from tests.conftest import ROOT

REFERENCE = ROOT / "benchmarks" / "results" / "regulation_scan.json"

#: the disc problem's lengths with l0 free in 290..310: the ratio grows with l0 and so does δ,
#: whose largest value over e in [0.2, 1] lies near e = 0.89, so the ripple cap binds inside
#: the interval
CAPPED = {
    "name": "capped", "mechanism": "fourbar_converter", "input_speed": 97.0,
    "stroke": "forward",
    "design": {"l0": {"lower": 290, "upper": 310, "initial": 292}, "l1": 20, "l2": 279.2,
               "l2_prime": 261.78, "l3": 80.67, "phases": 6},
    "constraints": {"min_transmission_angle_deg": 40},
    "objective": {"minimize": "-ratio", "max_ripple": 0.150},
    "regulation": {"eccentricity": {"lower": 0.2, "upper": 1.0}},
    "solver": {"workers": 1, "screen": 64},
}


def _problem(**changes):
    data = copy.deepcopy(CAPPED)
    data.update(changes)
    return problem_from_dict(data, where="p.yaml")


def test_the_worst_over_the_interval_is_a_dense_scans_worst():
    """Within 1e-6 of the largest δ of a 10 000-point scan of e (stored by
    benchmarks/regulation_scan.py; the scan's worst point is re-evaluated here, so the stored
    figure is this evaluator's)."""
    ref = json.loads(REFERENCE.read_text())
    problem = _problem()
    design = Design.from_problem(problem, ref["design"])
    at = _AtEccentricity(design, problem.stroke, problem.input_speed, "midrange")
    assert at(ref["scan_worst_eccentricity"], "none")[0] == \
        pytest.approx(ref["scan_worst_delta"], abs=1e-12)
    worst = worst_over_range(design, problem.stroke, problem.input_speed, "midrange",
                             ref["lower"], ref["upper"])
    assert ref["points"] == 10_000
    assert abs(worst.delta - ref["scan_worst_delta"]) <= 1e-6
    assert worst.interior(worst.eccentricity)                 # strictly inside [0.2, 1]
    assert abs(worst.eccentricity - ref["scan_worst_eccentricity"]) < 1e-3
    # no e of a coarser live scan is above the search's worst, and the ends are below it
    for e in np.linspace(ref["lower"], ref["upper"], 41):
        assert at(e, "none")[0] <= worst.delta + 1e-12
    assert worst.delta - max(at(ref["lower"], "none")[0], at(ref["upper"], "none")[0]) > 1e-4


def test_a_solve_holds_the_ripple_cap_over_the_whole_interval():
    problem = _problem()
    solver = PhaseSolver(problem, 6)
    result = solve_phase(problem, 6, solver=solver)
    assert result.status == "optimal"
    cap = problem.constraints.max_ripple
    # the worst over the interval, exact and re-checked here, is at the cap and strictly inside
    design = Design.from_problem(problem, result.design)
    worst = worst_over_range(design, problem.stroke, problem.input_speed, "midrange", 0.2, 1.0)
    assert result.delta == pytest.approx(worst.delta, abs=1e-12)
    assert worst.delta <= cap + 1e-7
    assert 0.5 < result.worst_eccentricity < 0.99
    assert worst.delta > cap - 1e-5                           # the cap binds inside
    # one NLP, its eccentricity slot moved as a parameter
    assert len(solver._nlps) == 1
    nlp = next(iter(solver._nlps.values()))
    assert nlp.n_slots == 2 and "eccentricity_slot0" in [b.name for b in nlp.layout.p]
    # the list form holds the ends only: its optimum breaks the cap inside the interval
    listed = _problem(regulation={"eccentricity": [0.2, 1.0]})
    assert listed.eccentricity_range is None
    other = solve(listed)
    assert other.status == "optimal" and other.delta <= cap + 1e-7
    assert other.worst_eccentricity is None and other.ratio > result.ratio
    inside = worst_over_range(Design.from_problem(listed, other.design), listed.stroke,
                              listed.input_speed, "midrange", 0.2, 1.0)
    assert inside.delta > cap + 5e-5


def test_the_list_form_builds_no_slot():
    listed = _problem(regulation={"eccentricity": [1.0, 0.5]})
    assert listed.eccentricities == (1.0, 0.5) and listed.eccentricity_range is None
    nlp = PhaseNLP(listed, 6)
    assert nlp.n_slots == 0 and nlp.tags == ["e1", "e0.5"]
    assert not any(b.name.startswith("eccentricity_") for b in nlp.layout.p)


def test_the_interval_is_read_with_its_ends_listed():
    problem = _problem(regulation={"eccentricity": {"lower": 0.25, "upper": 0.9}})
    assert problem.eccentricity_range == (0.25, 0.9)
    assert problem.eccentricities == (0.25, 0.9)


@pytest.mark.parametrize("value, message", [
    ({"lower": 0.5, "upper": 0.5}, "regulation.eccentricity.upper must exceed lower"),
    ({"lower": 0.5}, "regulation.eccentricity.upper is required"),
    ({"lower": 0.0, "upper": 1.0}, "regulation.eccentricity.lower must lie in"),
    ({"lower": 0.2, "upper": 1.5}, "regulation.eccentricity.upper must lie in"),
    ({"lower": 0.2, "upper": 1.0, "step": 0.1}, "regulation.eccentricity.step is not a known"),
    ("wide", "regulation.eccentricity must be a non-empty list of fractions in (0, 1] or an "
             "interval"),
])
def test_a_bad_interval_names_its_key(value, message):
    with pytest.raises(ProblemError) as err:
        _problem(regulation={"eccentricity": value})
    assert f"p.yaml: {message}" in str(err.value) and "\n" not in str(err.value)


def test_analyze_reports_and_draws_the_worst_eccentricity(tmp_path, capsys):
    """At l0 = 292 mm both ends meet the cap 0.14885 and the inside of the interval does not:
    analyze checks the cap over the whole interval, reports where it is worst and draws δ and
    the ratio against e."""
    import yaml

    from optdesign.cli import main

    data = copy.deepcopy(CAPPED)
    data["objective"]["max_ripple"] = 0.14885
    path = tmp_path / "capped.yaml"
    path.write_text(yaml.safe_dump(data))
    # the cap is violated inside the interval: the figures are printed and drawn, exit 1
    assert main(["analyze", str(path), "--json", "--out", str(tmp_path / "out")]) == 1
    captured = capsys.readouterr()
    assert captured.err.endswith("the design violates max_ripple\n")
    doc = json.loads(captured.out)
    worst = doc["regulation_range"]
    ends = [r["strokes"]["forward"]["delta"] for r in doc["regulation"]]
    assert worst["eccentricity_range"] == [0.2, 1.0] and 0.8 < worst["worst_eccentricity"] < 0.95
    assert max(ends) < 0.14885 < worst["delta"]
    cap = next(c for c in doc["constraints"] if c["name"] == "max_ripple")
    assert not cap["satisfied"] and cap["margin"] == pytest.approx(0.14885 - worst["delta"])
    assert (tmp_path / "out" / "regulation.png").stat().st_size > 10_000
    assert doc["units"]["worst_eccentricity"].startswith("-")

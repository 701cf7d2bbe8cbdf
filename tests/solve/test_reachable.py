"""Infeasible, in numbers (optdesign.solver.reachable): when no design meets a count's
constraints, the result names the constraint out of reach with the nearest value any design in
the bounds reaches, equal to what the solve with that figure as its objective finds."""
import json

import pytest

from optdesign.problem.loader import problem_from_dict
from optdesign.solver import solve
from tests.conftest import ROOT, file_data, run_main

DISC = ROOT / "problems" / "sharkov2022_disc.yaml"
HOUSING = ROOT / "problems" / "housing_disc.yaml"
#: two polishes a count: these problems' optima are found from the best two basins, and a
#: count no start can meet fails fast (each relaxed solve reads the same setting)
FEW = {"starts": 2}


def test_a_ratio_floor_out_of_reach_names_the_largest_ratio(write_problem, tmp_path):
    path = write_problem(file_data(DISC, objective__min_ratio=2.5, solver=FEW))
    code, text = run_main(["solve", path, "--out", tmp_path / "out", "--no-plots"])
    result = json.loads((tmp_path / "out" / "result.json").read_text())
    assert code == 1 and result["status"] == "infeasible"
    reach = result["per_phase"][0]["reachable"]
    assert reach["constraint"] == "min_ratio" and reach["side"] == "largest"
    assert reach["bound"] == 2.5 and reach["unit"] == "-"
    # the largest ratio: what minimize: -ratio with a slack ripple cap finds on the same file
    largest = solve(problem_from_dict(file_data(DISC, solver=FEW, objective={
        "minimize": "-ratio", "max_ripple": 10.0, "min_ratio": 0.0})))
    assert reach["value"] == pytest.approx(largest.ratio, abs=1e-6)
    assert f"min_ratio at least 2.5 is out of reach: the largest ratio any design in the " \
           f"bounds reaches with 6 phases is {reach['value']:.6g} (verified)" in text


def test_an_angle_out_of_reach_names_the_largest_least_angle():
    problem = problem_from_dict(file_data(DISC, constraints__min_transmission_angle_deg=80,
                                          solver=FEW))
    (phase,) = solve(problem).per_phase
    assert phase.status == "infeasible"
    reach = phase.reachable
    assert reach["constraint"] == "transmission_angle" and reach["unit"] == "deg"
    widest = solve(problem_from_dict(file_data(
        DISC, objective__minimize="-transmission_angle",
        constraints__min_transmission_angle_deg=0, solver=FEW)))
    assert reach["value"] == pytest.approx(widest.min_transmission_angle_deg, abs=1e-6)
    assert 40 < reach["value"] < 80
    assert "the largest least transmission angle any design in the bounds reaches with 6 " \
           "phases is" in phase.message


def test_a_casing_out_of_reach_names_the_least_housing_radius():
    data = file_data(HOUSING, objective__min_ratio=0, solver=FEW)
    data["constraints"] |= {"housing_radius": {"upper": 150}, "min_transmission_angle_deg": 0}
    (phase,) = solve(problem_from_dict(data)).per_phase
    assert phase.status == "infeasible" and phase.reachable["constraint"] == "housing_radius"
    del data["constraints"]["housing_radius"]
    data["objective"]["minimize"] = "housing_radius"
    least = solve(problem_from_dict(data))
    assert phase.reachable["value"] == pytest.approx(
        least.quantities["values"]["housing_radius"], rel=1e-7)
    assert phase.reachable["value"] > 150

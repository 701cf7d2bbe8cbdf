"""Criteria over quantities: ``constraints: {QUANTITY: {lower, upper, at}}`` and
``objective: {minimize: QUANTITY}`` (optdesign.quantities.bounds, optdesign.quantities.criteria).

Each optimum is re-verified exactly, a bound that binds holds to the check's tolerance, and no
design of a dense sample of the box that meets every constraint exactly beats the solve.
"""
import math

import numpy as np
import pytest

from optdesign.quantities.bounds import QuantityBound
from optdesign.quantities.criteria import objective_of, quantity_specs
from optdesign.errors import ProblemError
from optdesign.evaluation.figures import evaluate_problem
from optdesign.problem.loader import load_problem, problem_from_dict
from optdesign.quantities import design_quantities
from optdesign.solver import solve, verify
from tests.conftest import ROOT, file_data

HOUSING_FILE = ROOT / "problems" / "housing_disc.yaml"


def _data(**changes):
    return file_data(HOUSING_FILE, **changes)


# --------------------------------------------------------------------------- the file
@pytest.mark.parametrize("change,message", [
    ({"constraints__housing_radius": {}},
     r"constraints\.housing_radius needs a bound: upper or lower"),
    ({"constraints__housing_radius": {"lower": 300, "upper": 200}},
     r"constraints\.housing_radius\.upper must not be below lower"),
    ({"constraints__ratio": {"lower": 0.6, "upper": 0.5}},
     r"constraints\.ratio\.upper must not be below lower"),
    ({"constraints__housing_radius": {"upper": 250, "at": 0.5}},
     r"constraints\.housing_radius\.at must be worst or a listed eccentricity \(1\); got 0\.5"),
    ({"constraints__housing_radius": {"upper": "big"}},
     r"constraints\.housing_radius\.upper must be a number"),
    ({"constraints__casing": {"upper": 250}}, r"constraints\.casing is not a known key"),
    ({"constraints__transmission_angle": {"lower": 45}},
     r"constraints\.transmission_angle\.lower and constraints\.min_transmission_angle_deg "
     r"name the same bound: give one"),
    ({"objective__minimize": "casing"}, r"objective\.minimize must be one of"),
])
def test_bad_bounds_are_named(change, message):
    with pytest.raises(ProblemError, match=message):
        problem_from_dict(_data(**change), where="p.yaml")


def test_the_older_keys_and_their_quantity_names_load_the_same_problem():
    data = _data()
    del data["constraints"]["min_transmission_angle_deg"]
    del data["objective"]["min_ratio"]
    data["constraints"]["transmission_angle"] = {"lower": 40}
    data["constraints"]["ratio"] = {"lower": 0.3}
    a = problem_from_dict(data)
    data = _data(objective__min_ratio=0.3)
    b = problem_from_dict(data)
    assert a.constraints == b.constraints and a.objective == b.objective
    assert a.constraints.min_ratio == 0.3 and a.constraints.min_transmission_angle_deg == 40
    # the older keys are read into bounds on their quantities, not the other way round
    assert {"ratio", "transmission_angle"} <= {s.name for s in a.constraints.bounds}
    assert not {"ratio", "transmission_angle"} & {s.name for s in a.quantity_bounds}
    # a ripple cap is held with the largest ratio's objective, a bound of its own else
    c = problem_from_dict(_data(objective={"minimize": "-ratio"},
                                constraints__ripple={"upper": 0.2}))
    assert c.constraints.max_ripple == 0.2 and not any(
        s.name == "ripple" for s in c.quantity_bounds)
    d = problem_from_dict(_data(constraints__ripple={"upper": 0.2}))
    assert d.constraints.max_ripple == 0.2
    assert [s.key for s in quantity_specs(d)] == ["housing_radius", "ripple"]
    # objective.max_ripple is the same bound, whatever the objective
    e = problem_from_dict(_data(objective__max_ripple=0.2))
    assert e.constraints == d.constraints and e.quantity_bounds == d.quantity_bounds
    # a bound that only tracks a quantity (a front's axis) outlives a moved floor
    tracked = e.with_quantity_bounds(e.quantity_bounds + (QuantityBound("swing"),))
    moved = tracked.with_limit("ratio", "lower", 0.5).with_limit("ratio", "lower", None)
    assert "swing" in {s.key for s in moved.quantity_bounds}
    assert moved.constraints.min_ratio == 0.0


# --------------------------------------------------------------------------- solves
def _best_of_a_sample(problem, n=16384, verified=120):
    """The least objective key among the designs of a Sobol sample of the box (another seed
    than the solve's) that meet every constraint exactly: the ``verified`` best of those that
    pass the screening's filters, each checked by the exact evaluator."""
    from dataclasses import replace

    from optdesign.solver.screening import screen

    count = problem.counts()[0]
    other = replace(problem, solver=replace(problem.solver, seed=problem.solver.seed + 7))
    passed = sorted((c for c in screen(other, count, n).candidates if c.feasible),
                    key=lambda c: c.score)[:verified]
    keys = [ver.key for ver in (verify(problem, c.values, search=False) for c in passed)
            if ver.feasible]
    assert len(keys) >= 5, "too few sampled designs meet the constraints to compare"
    return min(keys)


def test_a_housing_bound_binds_exactly_and_no_sampled_design_beats_the_optimum():
    problem = load_problem(HOUSING_FILE)
    result = solve(problem)
    assert result.status == "optimal"
    bound = problem.quantity_bounds[0]
    values = result.quantities["values"]
    assert values["housing_radius"] <= bound.upper * (1 + 1e-7)
    assert values["housing_radius"] == pytest.approx(bound.upper, rel=1e-7)   # it binds
    casing = next(a for a in result.active if a["name"] == "housing_radius")
    assert casing["unit"] == "mm"
    assert casing["sensitivity"] == pytest.approx(-0.0013, abs=5e-5)     # docs/problems.md's figure
    ver = verify(problem, result.design)
    assert ver.feasible and ver.delta == pytest.approx(result.delta, abs=1e-12)
    assert ver.measured.quantities["housing_radius"] == pytest.approx(
        values["housing_radius"], rel=1e-12)
    # the casing costs ripple: the disc problem without it reaches less ripple and sweeps a
    # circle of l1 + l2 = 420 mm (docs/quantities.md)
    open_disc = solve(load_problem(ROOT / "problems" / "sharkov2022_disc.yaml"))
    assert open_disc.delta < result.delta - 1e-2
    assert open_disc.quantities["values"]["housing_radius"] == pytest.approx(420, rel=1e-7)
    assert result.delta <= _best_of_a_sample(problem) + 1e-9


@pytest.mark.parametrize("objective,name", [("housing_radius", "housing_radius"),
                                            ("-swing", "swing")])
def test_a_quantity_objective_is_optimised_and_verified(objective, name):
    problem = problem_from_dict(_data(objective__minimize=objective,
                                      constraints__swing={"lower": 30}))
    result = solve(problem)
    assert result.status == "optimal"
    ev = evaluate_problem(problem, result.design)
    exact = design_quantities(problem, ev)["values"]
    assert exact[name] == pytest.approx(result.quantities["values"][name], rel=1e-12)
    assert exact["swing"] >= 30 * (1 - 1e-7)
    key = objective_of(problem).result_key(result.best_phase())
    assert key <= _best_of_a_sample(problem) + 1e-9

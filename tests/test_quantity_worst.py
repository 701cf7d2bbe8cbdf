"""Quantities at their worst: over a regulation interval and over a tolerance box.

With ``regulation: {eccentricity: {lower, upper}}`` a bound on a quantity, or a quantity
objective, reads its worst over the whole interval: the exact search
(optdesign.evaluation.regulation) agrees with a dense scan of e, a solve holds a bound over
every e of the interval, and an interior worst is held in an eccentricity slot of the NLP as
the ripple's is (optdesign.solver.phase_solver.next_held). In a robust solve a bound holds for every
part of the tolerance box: its worst part is a scenario of the NLP (optdesign.solver.robust).
"""
import json

import numpy as np
import pytest

from optdesign.evaluation.design import Design
from optdesign.evaluation.regulation import _AtEccentricity, worst_over_range
from optdesign.problem.loader import load_problem, problem_from_dict
from optdesign.quantities import get_quantity
from optdesign.quantities.criteria import interval_quantities, searched_quantities
from optdesign.solver import verify
from optdesign.solver.phase_solver import PhaseSolver
from tests.conftest import ROOT, file_data, run_main

HOUSING_FILE = ROOT / "problems" / "housing_disc.yaml"
INTERVAL = {"eccentricity": {"lower": 0.2, "upper": 1.0}}


def _dense_worst(design, problem, name, lower=0.2, upper=1.0, n=81):
    """The worst of quantity ``name`` over ``n`` evenly spaced eccentricities, each exact."""
    at = _AtEccentricity(design, problem.stroke, problem.input_speed, problem.objective.ripple)
    values = np.array([at.quantity(name, e) for e in np.linspace(lower, upper, n)])
    return values.max() if get_quantity(name).worst == "max" else values.min()


def test_the_interval_search_agrees_with_a_dense_scan():
    problem = load_problem(HOUSING_FILE)
    design = Design.from_problem(problem)
    names = searched_quantities(design)
    assert set(names) == {"housing_radius", "peak_acceleration", "peak_speed", "swing"}
    worst = worst_over_range(design, problem.stroke, problem.input_speed,
                             problem.objective.ripple, 0.2, 1.0, quantities=names)
    assert worst.failure is None and set(worst.quantities) == set(names)
    for name in names:
        e, value = worst.quantities[name]
        dense = _dense_worst(design, problem, name)
        sign = 1.0 if get_quantity(name).worst == "max" else -1.0
        # never better than any point of the scan, and the value of the e it names
        assert sign * value >= sign * dense - 1e-9 * abs(dense), name
        assert value == pytest.approx(dense, rel=1e-9), name
        at = _AtEccentricity(design, problem.stroke, problem.input_speed, "midrange")
        assert at.quantity(name, e) == value


def test_a_housing_bound_is_held_over_the_whole_interval(tmp_path):
    data = file_data(HOUSING_FILE, regulation=INTERVAL)
    path = tmp_path / "housing_interval.yaml"
    import yaml
    path.write_text(yaml.safe_dump(data))
    problem = load_problem(path)
    assert interval_quantities(problem) == ("housing_radius",)
    code, _ = run_main(["solve", path, "--out", tmp_path / "out", "--no-plots"])
    result = json.loads((tmp_path / "out" / "result.json").read_text())
    assert code == 0 and result["status"] == "optimal"
    radius = result["quantities"]["values"]["housing_radius"]
    assert radius == pytest.approx(320, rel=1e-7) and radius <= 320 * (1 + 1e-7)
    # every quantity's worst over the interval, and where it lies
    interval = result["quantities"]["interval"]
    assert set(interval) >= {"housing_radius", "swing", "ripple", "transmission_angle"}
    assert interval["swing"]["eccentricity"] == pytest.approx(0.2)
    design = Design.from_problem(problem, result["design"])
    assert _dense_worst(design, problem, "housing_radius") <= 320 * (1 + 1e-7)
    assert verify(problem, result["design"]).feasible
    summary = (tmp_path / "out" / "summary.txt").read_text()
    assert "(worst over the listed eccentricities and the interval)" in summary


#: a quantity whose worst lies inside the interval: the crank pin's squared distance from O
#: against 15² mm², largest (zero) at e = 0.75 with the crank of 20 mm
BAND_MODULE = '''
import casadi as ca

from optdesign.quantities.base import TurnQuantity


class CrankBand(TurnQuantity):
    name = "crank_band"
    unit = "mm4"
    label = "crank band"
    meaning = "minus the squared gap of the crank pin's squared radius to 15 squared mm"
    worst = "max"

    def expression(self, model, phi, p, count):
        pin = model["joints"]["A"] - model["joints"]["O"]
        return [-(ca.sumsqr(pin) - 225.0) ** 2]
'''


@pytest.fixture
def band_quantity(add_quantity):
    add_quantity("band.py", BAND_MODULE)


def test_an_interior_worst_is_held_in_an_eccentricity_slot(band_quantity):
    data = file_data(HOUSING_FILE, regulation=INTERVAL)
    del data["constraints"]["housing_radius"]
    data["objective"]["minimize"] = "crank_band"
    problem = problem_from_dict(data)
    assert interval_quantities(problem) == ("crank_band",)
    solver = PhaseSolver(problem, 6)
    outcome = solver.solve_from(problem.start_values() | {"phases": 6})
    ver = outcome.verification
    assert outcome.record.feasible
    e, value = ver.evaluation.worst.quantities["crank_band"]
    assert e == pytest.approx(0.75, abs=1e-6) and value == pytest.approx(0.0, abs=1e-6)
    # the interval's worst e is held by the NLP, beside the listed ends
    assert any(abs(x - 0.75) < 1e-6 for x in ver.held.held())
    assert ver.measured.quantities["crank_band"] == value


def _corner_worst(problem, design, name):
    """The worst of quantity ``name`` over every corner of the problem's tolerance box, each
    part evaluated exactly."""
    import itertools

    from optdesign.evaluation.figures import evaluate_problem
    from optdesign.quantities.criteria import measured_quantities
    from optdesign.tolerance.parts import box_of

    box = box_of(problem, design, problem.sections["tolerances"])
    values = []
    for signs in itertools.product((-1.0, 1.0), repeat=box.toleranced.size):
        offsets = np.zeros(box.band.size)
        offsets[box.toleranced] = np.array(signs) * box.band[box.toleranced]
        ev = evaluate_problem(problem, box.part(offsets))
        values.append(measured_quantities(problem, ev)[name])
    return max(values), len(values)


def test_a_robust_solve_holds_a_housing_bound_for_every_part_of_the_box(tmp_path):
    data = file_data(HOUSING_FILE, objective__robust="worst_case", solver={"starts": 2},
                     tolerances={"default": 0.05, "lengths": {"l1": 0}})
    problem = problem_from_dict(data, where="housing_robust.yaml")
    # the nominal optimum sits on the casing: parts of its box break it
    nominal = json.loads(_solved(tmp_path, file_data(HOUSING_FILE))).get("design")
    worst_nominal, corners = _corner_worst(problem, nominal, "housing_radius")
    assert corners == 16 and worst_nominal > 320 + 0.01
    result = json.loads(_solved(tmp_path, data))
    assert result["status"] == "optimal"
    best = next(p for p in result["per_phase"] if p["status"] == "optimal")
    box_worst = best["worst_case_quantities"]["housing_radius"]
    assert box_worst == pytest.approx(320, rel=1e-7) and box_worst <= 320 * (1 + 1e-7)
    # the nominal keeps a margin, and no corner of its box breaks the casing
    assert result["quantities"]["values"]["housing_radius"] < 320 - 0.01
    worst, _ = _corner_worst(problem, result["design"], "housing_radius")
    assert worst <= 320 * (1 + 1e-7) and worst == pytest.approx(box_worst, rel=1e-9)
    summary = (tmp_path / "out" / "summary.txt").read_text()
    assert "the box's worst housing_radius = 320 mm" in summary


def _solved(tmp_path, data) -> str:
    """result.json of ``optdesign solve`` on the problem ``data``."""
    import yaml

    path = tmp_path / "p.yaml"
    path.write_text(yaml.safe_dump(data))
    code, _ = run_main(["solve", path, "--out", tmp_path / "out", "--no-plots"])
    assert code == 0
    return (tmp_path / "out" / "result.json").read_text()


def test_the_summary_says_where_each_bounded_quantity_is_read(tmp_path):
    """The ratio's bound is read at e = 1 (its definition), a housing bound at its worst over
    the listed eccentricities: the summary's quantities line says which, quantity by quantity
    (it said "worst over the listed eccentricities" of both, and printed the ratio at e = 1)."""
    import yaml

    data = file_data(HOUSING_FILE)
    data["design"]["phases"] = 4
    data["regulation"] = {"eccentricity": [1.0, 0.5]}
    data.setdefault("constraints", {})["ratio"] = {"upper": 0.6}
    path = tmp_path / "capped.yaml"
    path.write_text(yaml.safe_dump(data))
    code, _ = run_main(["solve", path, "--out", tmp_path / "out", "--no-plots"])
    result = json.loads((tmp_path / "out" / "result.json").read_text())
    assert code == 0 and result["status"] == "optimal"
    line = next(x for x in (tmp_path / "out" / "summary.txt").read_text().splitlines()
                if x.startswith("quantities: "))
    ratio = result["quantities"]["values"]["ratio"]
    assert ratio == pytest.approx(result["ratio"], rel=1e-12)      # the ratio at e = 1
    assert f"ratio = {ratio:.6g} (at e = 1)" in line
    assert "housing_radius = " in line and \
        "mm (worst over the listed eccentricities)" in line
    binding = next(x for x in (tmp_path / "out" / "summary.txt").read_text().splitlines()
                   if x.startswith("binding: "))
    assert ".attained" not in binding            # the NLP's row names are not the file's
    names = {a["name"] for a in result["active"]}      # result.json keeps the rows' names
    assert {"ratio.attained", "housing_radius"} <= names
    assert "constraints.ratio.upper (d" in binding and \
        "constraints.housing_radius.upper (d" in binding

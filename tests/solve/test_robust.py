"""The robust solve, ``objective: {robust: worst_case}``: the worst δ over the tolerance box is
minimised and every part of the box keeps every constraint (docs/formulation.md, "Robust
solve"), checked here by the tolerance analysis's worst case and a Monte Carlo sample."""
import copy
import math

import pytest
import yaml

from optdesign.errors import ProblemError
from optdesign.problem.loader import problem_from_dict
from optdesign.solver import PhaseSolver, solve_phase
from optdesign.tolerance.montecarlo import monte_carlo
from optdesign.tolerance.worst_case import worst_case
from tests.conftest import ROOT

#: the disc problem with ± 0.5 mm on every length (the crank ± 0.02 mm) and a least
#: transmission angle of 5°: the nominal optimum sits on the angle bound, where the box's
#: parts fold past the toggle
BASE = yaml.safe_load((ROOT / "problems" / "sharkov2022_disc_tolerance.yaml").read_text())
BASE["constraints"]["min_transmission_angle_deg"] = 5
BASE["tolerances"]["default"] = 0.5
BASE["solver"] = {"workers": 1, "basins": 1, "starts": 1, "screen": 64}


def _problem(**objective):
    data = copy.deepcopy(BASE)
    data["objective"] = data["objective"] | objective
    return problem_from_dict(data, where="p.yaml")


def test_the_robust_optimum_keeps_every_part_and_lowers_the_worst_ripple():
    nominal_problem, robust_problem = _problem(), _problem(robust="worst_case")
    box = robust_problem.sections["tolerances"]
    nominal = solve_phase(nominal_problem, 6, solver=PhaseSolver(nominal_problem, 6))
    solver = PhaseSolver(robust_problem, 6)
    robust = solve_phase(robust_problem, 6, solver=solver)
    assert nominal.status == robust.status == "optimal"
    # the tolerance analysis of both optima: the nominal's box holds parts that do not
    # assemble (its worst δ is infinite), the robust one's worst δ is its objective
    nominal_worst = worst_case(nominal_problem, nominal.design, box)
    robust_worst = worst_case(robust_problem, robust.design, box)
    assert robust_worst.assembles and math.isfinite(robust_worst.value)
    assert robust_worst.value < nominal_worst.value
    assert robust.worst_case_delta == pytest.approx(robust_worst.value, rel=1e-9)
    assert robust.delta < robust.worst_case_delta      # the nominal part is not the worst
    # every one of 10 000 parts assembles and keeps the angle; not so the nominal optimum's
    parts = monte_carlo(robust_problem, robust.design, box, samples=10_000, seed=3)
    assert parts["assembles"].all()
    assert parts["mu_min_deg"].min() >= 5.0 - 1e-6
    assert robust.worst_case_min_transmission_angle_deg >= 5.0 - 1e-3
    pins = (robust.design["l2"] + parts["l2_offset_mm"]) - \
        (robust.design["l2_prime"] + parts["l2_prime_offset_mm"])
    assert pins.min() >= 125.0 - 1e-6                  # the disc's pin radius, every part
    before = monte_carlo(nominal_problem, nominal.design, box, samples=10_000, seed=3)
    assert not before["assembles"].all() or before["mu_min_deg"].min() < 5.0
    # the NLP was built once: the parts are parameters of its scenario slots
    assert len(solver._nlps) == 1
    nlp = next(iter(solver._nlps.values()))
    assert nlp.n_scenarios == 4 and "offsets_s0" in [b.name for b in nlp.layout.p]


@pytest.mark.parametrize("change, message", [
    ({"drop": "tolerances"}, "objective.robust worst_case needs a tolerances: section"),
    ({"objective": {"minimize": "-ratio", "max_ripple": 0.5}},
     "objective.robust worst_case needs minimize: ripple"),
    ({"regulation": {"eccentricity": {"lower": 0.5, "upper": 1.0}}},
     "objective.robust worst_case needs listed eccentricities"),
    ({"objective": {"robust": "average"}}, "objective.robust must be one of none, worst_case"),
])
def test_a_robust_objective_needs_its_box(change, message):
    data = copy.deepcopy(BASE)
    data["objective"]["robust"] = "worst_case"
    for key, value in change.items():
        if key == "drop":
            del data[value]
        elif key == "objective":
            data["objective"] |= value
        else:
            data[key] = value
    with pytest.raises(ProblemError) as err:
        problem_from_dict(data, where="p.yaml")
    assert f"p.yaml: {message}" in str(err.value) and "\n" not in str(err.value)


def test_without_robust_the_nlp_has_no_scenario():
    from optdesign.solver.nlp import PhaseNLP

    problem = _problem()
    assert problem.objective.robust == "none"
    nlp = PhaseNLP(problem, 6)
    assert nlp.n_scenarios == 0 and not any(b.name.startswith("offsets_")
                                            for b in nlp.layout.p)


def test_a_robust_solve_starts_from_the_nominal_optimum():
    """The robust solve polishes the nominal problem first, then once from its optimum (held
    at the box's worst corners from the first round), and its worst δ is the tolerance
    analysis's, above the nominal optimum's δ."""
    from dataclasses import replace

    from optdesign.problem.loader import load_problem

    problem = load_problem(ROOT / "problems" / "robust_fourbar.yaml")
    plain = replace(problem, objective=replace(problem.objective, robust="none"))
    nominal = solve_phase(plain, 4, workers=1)
    robust = solve_phase(problem, 4, workers=1)
    assert nominal.status == robust.status == "optimal"
    assert robust.screening["polished"] == nominal.screening["polished"]
    assert robust.screening["robust_polished"] == 1
    assert len(robust.starts) == nominal.screening["polished"] + 1
    start = robust.starts[-1].start
    assert all(start[k] == pytest.approx(v, abs=1e-9) for k, v in nominal.design.items())
    found = worst_case(problem, robust.design, problem.sections["tolerances"])
    assert robust.worst_case_delta == pytest.approx(found.value, rel=1e-9)
    assert robust.worst_case_delta > robust.delta >= nominal.delta - 1e-12
    assert robust.worst_case_min_transmission_angle_deg >= 45.0 - 1e-3


def test_the_tolerance_analysis_in_two_processes_is_the_one_in_one():
    from optdesign.solver.robust import worst_cases

    problem = _problem(robust="worst_case")
    design = problem.start_values()
    serial, corners = worst_cases(problem, design)
    forked, corners_forked = worst_cases(problem, design, in_parallel=True)
    assert [(c.quantity, c.value, c.deviation) for c in serial] == \
        [(c.quantity, c.value, c.deviation) for c in forked]
    assert corners == corners_forked


def test_a_new_part_takes_the_slot_of_a_held_part_that_does_not_bind():
    """Every slot held: the part wanted now replaces the oldest part that does not bind, and
    the oldest part only when every held part binds."""
    from optdesign.solver.nlp import Held
    from optdesign.solver.robust import next_scenarios
    from optdesign.tolerance.worst_case import WorstCase

    problem = _problem(robust="worst_case")
    names = problem.model.lengths
    parts = [tuple(0.5 * (1 if (i >> k) & 1 else -1) for k in range(len(names)))
             for i in range(5)]
    held = Held(offsets=tuple(parts[:4]), scenario_active=(True,) * 4)

    def case(quantity, value, offsets):
        return WorstCase(quantity, value, dict(zip(names, offsets)), {}, 1)
    rougher = [case("ripple", 0.2, parts[4]), case("transmission_angle", 30.0, parts[0])]
    kept = next_scenarios(problem, held, rougher, bound=0.1, binding=(parts[0], parts[2]))
    assert kept.offsets == (parts[0], parts[2], parts[3], parts[4])
    every = next_scenarios(problem, held, rougher, bound=0.1, binding=tuple(parts[:4]))
    assert every.offsets == (parts[1], parts[2], parts[3], parts[4])

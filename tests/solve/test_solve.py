"""The NLP: returned designs are feasible by the exact evaluator, infeasibility is detected and
named, phase counts are enumerated, fixed and free variables are honoured."""
import json

import pytest
import yaml

from optdesign.cli import main
from optdesign.problem.loader import load_problem, problem_from_dict
from optdesign.solver import solve, verify
from tests.conftest import ROOT, file_data

DISC = ROOT / "problems" / "sharkov2022_disc.yaml"


def disc(**changes) -> dict:
    return file_data(DISC, **changes)


@pytest.fixture(scope="module")
def disc_result():
    return solve(load_problem(DISC))


def test_disc_problem_halves_the_papers_ripple(disc_result):
    """The disc problem: the paper's disc (pin radius >= 125 mm kept), μ >= 40°, ratio >= 0.344:
    δ at least halved from the paper's 0.376, ratio not lower."""
    r = disc_result
    assert r.status == "optimal"
    assert r.delta <= 0.376 / 2
    assert r.ratio >= 0.344
    assert r.min_transmission_angle_deg >= 40 - 1e-3
    assert r.design["l2"] - r.design["l2_prime"] >= 125 - 1e-5
    assert r.design["l1"] == 20 and r.design["phases"] == 6          # fixed stay fixed
    for k in ("l0", "l2", "l2_prime", "l3"):                         # free stay in bounds
        b = load_problem(DISC).design[k]
        assert b.lower <= r.design[k] <= b.upper


def test_optimum_is_reverified_exactly(disc_result):
    p = load_problem(DISC)
    ver = verify(p, disc_result.design)
    assert ver.feasible
    assert ver.delta == pytest.approx(disc_result.delta, rel=1e-12)
    ph = disc_result.per_phase[0]
    assert abs(ph.surrogate_gap) < 1e-6         # the NLP's δ is exact at the optimum
    assert all(s.iterations > 0 for s in ph.starts)


def test_known_optimum_of_the_disc_problem(disc_result):
    """Reference: δ = 0.140214 (this solver, cross-checked by differential evolution in
    benchmarks/solve_vs_peers.py, docs/benchmarks.md). Tolerance 1e-5: IPOPT's tol is 1e-9."""
    assert disc_result.delta == pytest.approx(0.140214, abs=1e-5)


def test_a_pin_radius_beyond_the_box_is_infeasible_with_the_reachable_value(write_problem):
    """l2 − l2′ is at most 400 − 30 = 370 mm in the disc problem's box: decided from the
    bounds, before any screening or IPOPT iteration."""
    data = disc(constraints={**disc()["constraints"], "min_pin_radius": 500})
    r = solve(load_problem(write_problem(data)))
    (phase,) = r.per_phase
    assert r.status == "infeasible" and phase.binding == "pin_radius"
    assert phase.iterations == 0 and not phase.starts
    assert phase.message == ("pin_radius must be at least 500 mm, and no design in the bounds "
                             "reaches it: the largest pin_radius the bounds allow is 370 mm")


def test_every_phase_count_is_reported(write_problem):
    data = disc(design={**disc()["design"], "phases": {"choices": [4, 8]}})
    r = solve(load_problem(write_problem(data)))
    assert [p.phases for p in r.per_phase] == [4, 8]
    assert all(p.status == "optimal" for p in r.per_phase)
    best = min(r.per_phase, key=lambda p: p.delta)
    assert r.design["phases"] == best.phases == 8         # more phases, less ripple


def test_all_fixed_design_is_evaluated_not_moved(write_problem):
    data = yaml.safe_load((ROOT / "problems" / "sharkov2022.yaml").read_text())
    data["constraints"]["min_transmission_angle_deg"] = 20
    r = solve(load_problem(write_problem(data)))
    assert r.status == "optimal"
    assert r.design == {"l0": 225, "l1": 20, "l2": 225, "l2_prime": 100, "l3": 56, "phases": 6}
    assert r.delta == pytest.approx(0.3764, abs=1e-4)


def test_fixed_design_violating_the_angle_is_infeasible(write_problem):
    data = yaml.safe_load((ROOT / "problems" / "sharkov2022.yaml").read_text())
    data["constraints"]["min_transmission_angle_deg"] = 60       # the paper's design: 56.7°
    r = solve(load_problem(write_problem(data)))
    assert r.status == "infeasible"
    assert "transmission_angle" in r.per_phase[0].binding


def test_most_ratio_under_a_ripple_cap(write_problem):
    data = disc(objective={"minimize": "-ratio", "max_ripple": 0.2, "min_ratio": 0.3})
    r = solve(load_problem(write_problem(data)))
    assert r.status == "optimal"
    assert r.delta <= 0.2 + 1e-7
    assert r.ratio > 0.7


def test_worst_case_over_eccentricities(write_problem):
    data = disc(regulation={"eccentricity": [1.0, 0.5]})
    r = solve(load_problem(write_problem(data)))
    assert r.status == "optimal"
    worst = max(row["delta"] for row in r.per_phase[0].regulation)
    assert r.delta == pytest.approx(worst, rel=1e-12)


def test_driveline_speed_limit_binds(write_problem):
    """A 1:15 step-up after the variator drives the car shaft of problems/driveline.yaml: the
    shaft's 0.7·ω_cr caps the variator's peak output speed."""
    dl = yaml.safe_load((ROOT / "problems" / "driveline.yaml").read_text())["driveline"]
    dl["speed_factor"] = 15.0
    free = disc(driveline=dl)
    capped = disc(driveline=dl, constraints={**disc()["constraints"],
                                             "max_speed_fraction_of_critical": 0.7})
    r_free = solve(load_problem(write_problem(free, "free.yaml")))
    r_cap = solve(load_problem(write_problem(capped, "capped.yaml")))
    assert r_free.status == r_cap.status == "optimal"
    p = load_problem(write_problem(capped, "capped.yaml"))
    w_cr = p.sections["driveline"].critical_speed
    peak = r_cap.per_phase[0].regulation[0]["omega_max"]
    assert 15 * peak <= 0.7 * w_cr * (1 + 1e-6)
    assert r_cap.delta >= r_free.delta - 1e-9


def test_problem_given_in_code():
    data = disc()
    p = problem_from_dict(data, where="notebook")
    assert p.free_lengths() == ["l0", "l2", "l2_prime", "l3"]


def test_nothing_assembles_within_the_bounds(write_problem, capsys):
    data = disc(design={**disc()["design"], "l3": {"lower": 1, "upper": 2}})
    assert main(["solve", str(write_problem(data)), "--json", "--no-plots", "--out",
                 str(write_problem(data).parent / "o")]) == 1
    result = json.loads(capsys.readouterr().out)
    assert result["status"] == "infeasible"
    assert result["per_phase"][0]["binding"] == "assembly"
    assert "no design within the bounds assembles" in result["per_phase"][0]["message"]


def test_grashof_constraint_is_wired_and_met(write_problem):
    data = disc(constraints={**disc()["constraints"], "grashof": True})
    r = solve(load_problem(write_problem(data)))
    assert r.status == "optimal"
    d = r.design
    longest = max(d["l0"], d["l2"], d["l3"])
    assert d["l1"] + longest <= d["l0"] + d["l2"] + d["l3"] - longest + 1e-6


def test_the_result_answers_to_scipys_names():
    """``success``, ``x``, ``fun`` and ``nit`` as scipy.optimize.OptimizeResult has them."""
    import numpy as np

    from optdesign.problem.loader import load_problem
    from optdesign.solver import solve
    from tests.conftest import ROOT

    problem = load_problem(ROOT / "problems" / "housing_disc.yaml")
    r = solve(problem)
    assert r.success is True and r.nit == r.iterations > 0
    assert r.fun == r.delta
    np.testing.assert_array_equal(r.x, [r.design[k] for k in problem.model.lengths])
    from dataclasses import replace
    least = solve(replace(problem, objective=replace(problem.objective,
                                                     minimize="housing_radius")))
    assert least.fun == least.quantities["values"]["housing_radius"]

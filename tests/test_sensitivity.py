"""Exact sensitivities of a design (optdesign.evaluation.sensitivity) against finite differences of the
exact evaluator.

Central differences with h = 1e-4 mm: their truncation error is O(h²·f''') ~ 1e-9 relative and
the exact evaluator's figures are exact to ~1e-14 (Brent's method to machine precision), so
the symbolic derivatives must agree to 1e-6 relative (1e-9 per mm absolute for the
derivatives that are ~0). Measured: 1e-8 relative or better on every length below.
"""
from dataclasses import replace

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from optdesign.evaluation.design import Design
from optdesign.evaluation.figures import evaluate_problem
from optdesign.problem.loader import load_problem
from optdesign.evaluation.sensitivity import sensitivities
from tests.conftest import ROOT, near_starter

H = 1e-4                      # mm
REL, ABS = 1e-6, 1e-9         # see the module docstring


def figures(problem, values):
    """(worst δ over the listed e, ratio at e = 1, least transmission angle margin, deg)."""
    ev = evaluate_problem(problem, values)
    assert ev.assembles
    return (ev.ripple(problem.objective.ripple, problem.eccentricities), ev.ratio,
            ev.min_angle_deg - problem.constraints.min_transmission_angle_deg)


def central(problem, values, key, which):
    up, down = dict(values), dict(values)
    up[key] += H
    down[key] -= H
    return (figures(problem, up)[which] - figures(problem, down)[which]) / (2 * H)


def assert_matches_central(problem, values, which=(0, 1, 2)):
    s = sensitivities(problem, values)
    blocks = (s.d_delta, s.d_ratio, s.d_margin)
    for key in problem.model.lengths:
        for i in which:
            assert blocks[i][key] == pytest.approx(central(problem, values, key, i),
                                                   rel=REL, abs=ABS), (key, i)
    return s


@pytest.fixture(scope="module")
def disc():
    from optdesign.solver.driver import solve

    problem = load_problem(ROOT / "problems" / "sharkov2022_disc.yaml")
    result = solve(problem)
    assert result.status == "optimal"
    return problem, result


def test_disc_optimum_delta_and_ratio_match_finite_differences(disc):
    problem, result = disc
    s = assert_matches_central(problem, result.design, which=(0, 1))
    assert s.delta == pytest.approx(result.delta, abs=1e-12)
    assert s.eccentricity == 1.0
    assert not any(figure == "delta" for figure, _ in s.kinks)
    assert abs(s.d_delta["l3"]) > 1e-3          # not a trivially zero derivative


def least_angle(problem, values):
    """The least transmission angle found independently of the evaluator: every local peak
    of |cos μ| on a 4096-point grid, refined by a bounded search (deg)."""
    design = Design.from_problem(problem, values)
    phi = np.linspace(0, 2 * np.pi, 4096, endpoint=False)
    cos_mu = np.abs(design.sample(phi)["cos_mu"])
    worst = 0.0
    for k, row in enumerate(cos_mu):
        for j in np.nonzero((row >= np.roll(row, 1)) & (row >= np.roll(row, -1)))[0]:
            res = minimize_scalar(lambda t: -abs(design.chain_at(t, k)[3]),
                                  bounds=(phi[j] - 0.002, phi[j] + 0.002), method="bounded",
                                  options={"xatol": 1e-12})
            worst = max(worst, -res.fun)
    return np.degrees(np.arccos(worst))


def test_disc_optimum_margin_is_a_kink_with_its_right_sided_slope(disc):
    """The optimum holds chain 3 at 40° on both sides of its toggle (largest and least
    cos μ), with different slopes: a kink, flagged, and the value given is the derivative
    for +h (forward differences of an independent least angle, to 1e-4: the two sides
    differ by 6e-9 deg, 6e-5 of a forward step's change)."""
    problem, result = disc
    s = sensitivities(problem, result.design)
    assert s.kink and [f for f, _ in s.kinks] == ["transmission_angle_margin"]
    base = least_angle(problem, result.design)
    assert base - 40.0 == pytest.approx(s.margin_deg, abs=1e-7)
    for key in problem.model.lengths:
        up = dict(result.design)
        up[key] += H
        forward = (least_angle(problem, up) - base) / H
        assert s.d_margin[key] == pytest.approx(forward, rel=1e-4, abs=1e-6), key


def test_slotted_lever_matches_finite_differences():
    """vergov.yaml (XD and L fixed; e = 1 and 0.5): one section rests at δ = 2 (dδ/dl = 0),
    two sections have their worst δ at e = 0.5, where L enters as 0.5·L."""
    problem = load_problem(ROOT / "problems" / "vergov.yaml")
    one = assert_matches_central(problem, problem.start_values())
    assert one.delta == pytest.approx(2.0)
    assert max(abs(v) for v in one.d_delta.values()) < 1e-12
    two = assert_matches_central(problem, problem.start_values() | {"sections": 2})
    assert two.eccentricity == 0.5 and abs(two.d_delta["L"]) > 1e-3
    assert two.d_margin == {"XD": 0.0, "L": 0.0}         # cos μ = 0: μ = 90° always


@pytest.mark.parametrize("ripple", ["midrange", "mean"])
def test_fourbar_with_every_length_free_matches_finite_differences(ripple):
    problem = load_problem(ROOT / "problems" / "pareto_fourbar.yaml")
    problem = replace(problem, objective=replace(problem.objective, ripple=ripple))
    assert all(problem.design[k].is_free for k in problem.model.lengths)
    s = assert_matches_central(problem, problem.start_values() | {"phases": 4})
    assert not s.kink and s.ripple == ripple


def test_a_solve_carries_the_block_and_prints_one_line(disc):
    from optdesign.solver.outputs import summary_text

    problem, result = disc
    block = result.to_dict()["sensitivities"]
    assert set(block["d_delta_d_length_per_mm"]) == set(problem.model.lengths)
    assert block == result.per_phase[0].sensitivities == result.sensitivities
    line = next(x for x in summary_text(result, problem).splitlines()
                if x.startswith("sensitive:"))
    assert line.startswith("sensitive: dδ/dl3 = +4.67e-03 /mm, dδ/dl1 = -2.83e-03 /mm")
    units = result.to_dict()["units"]
    assert units["d_transmission_angle_margin_d_length_deg_per_mm"].startswith("deg/mm")


def test_only_the_answer_carries_sensitivities():
    """Computed for the answer alone: the other counts' blocks are empty, and the answer's
    is the block of its design, exactly."""
    from optdesign.solver import solve

    problem = load_problem(ROOT / "problems" / "vergov_solve.yaml")
    result = solve(problem)
    assert [p.status for p in result.per_phase] == ["optimal", "optimal"]
    best = result.best_phase()
    assert best.sensitivities == result.sensitivities == \
        sensitivities(problem, result.design).to_dict()
    assert [p.sensitivities for p in result.per_phase if p is not best] == [{}]


def test_the_api_gives_a_design_s_sensitivities():
    import optdesign

    s = optdesign.sensitivities(ROOT / "problems" / "sharkov2022.yaml", {"l3": 60.0})
    assert s.to_dict()["d_delta_d_length_per_mm"].keys() == {"l0", "l1", "l2", "l2_prime", "l3"}
    assert s.most_sensitive(1)[0][0] == "l1"


def test_an_interior_worst_eccentricity_of_a_regulation_interval(disc):
    """With δ held over e in [0.2, 1], the disc optimum's worst e lies inside (≈ 0.48): δ is
    smooth in e there, so dδ/dl is taken at that e fixed. 1e-5: the evaluator locates the
    worst e by a search, whose error enters its δ at second order (measured 1e-7)."""
    _, result = disc
    problem = load_problem(ROOT / "problems" / "sharkov2022_disc_interval.yaml")
    s = sensitivities(problem, result.design)
    assert 0.2 < s.eccentricity < 1.0
    for key in ("l0", "l3"):
        assert s.d_delta[key] == pytest.approx(central(problem, result.design, key, 0),
                                               rel=1e-5), key


def test_an_output_at_rest_is_no_kink():
    """The pulse reducer with two drives stops at its dead centres (breakpoints): ω_min = 0
    at six points whose slopes are all 0 up to rounding (~1e-11 per mm), so no kink."""
    problem = load_problem(ROOT / "problems" / "pulse_reducer_solve.yaml")
    values = problem.start_values() | {"r1": 39.45, "a": 50.0, "R1": 250.0, "freewheels": 2}
    s = assert_matches_central(problem, values)
    assert s.delta == pytest.approx(2.0) and not s.kink


@pytest.mark.parametrize("mechanism, count", [("fourbar_converter", 6), ("slotted_lever", 3),
                                              ("pulse_reducer", 4)])
def test_a_chain_s_gradients_come_from_its_own_function_bit_for_bit(mechanism, count):
    """The gradients are taken on chain k's own function (the solve's NLP built it): the same
    figures, to the bit, as on chain k of the mechanism's whole kinematics."""
    import casadi as ca

    from optdesign.evaluation.sensitivity import _gradient_function
    from optdesign.mechanisms import get_mechanism

    model = get_mechanism(mechanism)
    options = tuple(sorted(model.default_options().items()))
    rng = np.random.default_rng(3)
    phi, p = ca.SX.sym("phi"), ca.SX.sym("p", len(model.lengths))
    for k in range(count):
        whole = [v[k] for v in model.kinematics(count, options).call([phi, p], True, False)]
        theta, dtheta, _, cos_mu = whole
        reference = ca.Function("whole", [phi, p], whole + [
            ca.jacobian(theta, p), ca.jacobian(dtheta, p), ca.jacobian(cos_mu, p)])
        for _ in range(3):
            angles = ca.DM(rng.uniform(0.0, 2 * np.pi, 5)).T
            lengths = ca.DM(near_starter(model, rng, 0.02))
            got = _gradient_function(mechanism, count, options, k)(angles, lengths)
            for a, b in zip(got, reference(angles, lengths)):
                assert np.array_equal(np.array(a), np.array(b), equal_nan=True)


@pytest.mark.parametrize("path, count", [("sharkov2022_disc.yaml", 6),
                                         ("pareto_fourbar.yaml", 4), ("vergov.yaml", 2)])
def test_the_evaluation_s_sampling_and_stationary_points_give_the_same_block(path, count):
    """The sensitivities read the evaluation's grid sampling and its runs' stationary points
    (found by the exact evaluator on the same grid); found afresh, every figure of the block
    is the same to the bit."""
    problem = load_problem(ROOT / "problems" / path)
    values = problem.start_values() | {problem.model.count_variable: count}
    ev = evaluate_problem(problem, values)
    assert all(x.sampled is not None and x.grid is not None for x in ev.per_e)
    assert any(run.stationary for x in ev.per_e for run in x.runs)
    bare = replace(ev, per_e=[replace(x, sampled=None, grid=None,
                                      runs=[replace(r, stationary=None) for r in x.runs])
                              for x in ev.per_e])
    assert sensitivities(problem, values, ev).to_dict() == \
        sensitivities(problem, values, bare).to_dict()

"""The pulse reducer against Ambartsumyants & Subbotina 2015 eqs. (1)-(2) and its closed forms."""
import json
import math
import re

import casadi as ca
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
import yaml

from optdesign.cli import main
from optdesign.evaluation.design import Design
from optdesign.envelope.exact import exact_figures
from optdesign.mechanisms import get_mechanism
from optdesign.mechanisms.pulse_reducer import paper_position, position_function
from optdesign.problem.loader import Constraints, load_problem
from tests.conftest import ROOT

PROBLEM = ROOT / "problems" / "pulse_reducer.yaml"
PAPER = dict(r1=5.0, a=50.0, R1=250.0, freewheels=2)   # mm; a is our choice (see the YAML)
W1 = 97.0                                              # rad/s, the paper's ω


def design(**changes):
    return Design("pulse_reducer", PAPER | changes)


def test_output_advances_4r_over_R_per_turn():
    """Closed form of eqs. (1)-(2): Φ(2π) - Φ(0) = 4r/R, so the ratio is 4·r1/(2π·R1). The exact
    evaluator sums angle increments: only rounding error, hence rel 1e-12."""
    f, _ = exact_figures(design(), "forward", W1)
    assert f.ratio == pytest.approx(4 * 5.0 / (2 * math.pi * 250.0), rel=1e-12)
    assert f.omega_mean == pytest.approx(W1 * f.ratio, rel=1e-15)


def test_extremes_closed_form():
    """Holder speed r·sin φ/(R·√(1 - 2r·cos φ + r²)) peaks at cos φ = r with value r/R = r1/R1;
    with two freewheels the output stops at the dead centres: ω_min = 0, δ = 2, δ_mean = π/2."""
    f, _ = exact_figures(design(), "forward", W1)
    assert f.omega_max == pytest.approx(W1 * 5.0 / 250.0, rel=1e-12)
    assert f.omega_min == pytest.approx(0.0, abs=1e-12)
    assert f.delta == pytest.approx(2.0, rel=1e-12)
    assert f.delta_mean == pytest.approx(math.pi / 2, rel=1e-12)


@pytest.mark.parametrize("a", [5.5, 50.0, 1e4])
@pytest.mark.parametrize("n", [1, 2, 3, 4, 6])
def test_figures_closed_form_for_any_count_and_any_a(n, a):
    """With the holders' speeds (r1/R1)·sin(φ - α_k) (the limit a → ∞) the envelope gives
    ω_max = ω1·r1/R1, ω_min = ω1·(r1/R1)·cos(π/n) and a mean ω1·(r1/R1)·n·sin(π/n)/π (n >= 2;
    n = 1: ω_min = 0, mean ω1·r1/(π·R1)). The same figures hold at every finite a we tried
    (a/r1 from 1.1 to 2000), to rounding: pinned at rel 1e-11 (docs/mechanisms.md)."""
    f, _ = exact_figures(design(a=a, freewheels=n), "forward", W1)
    k = W1 * 5.0 / 250.0
    low = k * math.cos(math.pi / n) if n >= 2 else 0.0
    mean = k * n * math.sin(math.pi / n) / math.pi if n >= 2 else k / math.pi
    assert f.omega_max == pytest.approx(k, rel=1e-11)
    assert f.omega_min == pytest.approx(low, rel=1e-11, abs=1e-14)
    assert f.omega_mean == pytest.approx(mean, rel=1e-11)


def test_envelope_integral_is_the_papers_position_function():
    """∫ max(0, θ_1', θ_2') dφ from 0 is eqs. (1)-(2): on [0, π] θ_1 - θ_1(0), on [π, 2π]
    2r/R + θ_2 - θ_2(π); both are the same algebra, so agreement to 1e-14."""
    r, big_r = 0.1, 5.0
    phi = np.linspace(0, 2 * np.pi, 721)
    theta = design().sample(phi)["theta"]
    rebuilt = np.where(phi <= np.pi, theta[0] - theta[0, 0], 2 * r / big_r + theta[1])
    paper = np.array([float(paper_position(x, r, big_r)) for x in phi])
    assert np.max(np.abs(rebuilt - paper)) < 1e-14
    # and the trapezoid integral of the sampled envelope (error O(h²) ~ 1e-8 at 2e4 samples)
    fine = np.linspace(0, 2 * np.pi, 20001)
    env = np.maximum(design().sample(fine)["dtheta"].max(axis=0), 0.0)
    integral = np.concatenate([[0.0], np.cumsum(0.5 * (env[1:] + env[:-1]) * np.diff(fine))])
    paper_fine = np.array([float(paper_position(x, r, big_r)) for x in fine[::500]])
    assert np.max(np.abs(integral[::500] - paper_fine)) < 1e-8


def test_position_is_continuous_at_the_switch_points():
    """Φ and Φ' are continuous at φ = 0, π, 2π (Φ' = 0 there: the output stops); Φ'' jumps from
    -r/(R(1+r)) to r/(R(1-r)) at π and from -r/(R(1+r)) to r/(R(1-r)) at 2π (next turn)."""
    r1, a, big_r = 5.0, 50.0, 250.0
    r, rr = r1 / a, big_r / a
    fn = position_function()
    eps = 1e-9
    for x in (np.pi, 2 * np.pi):
        left, right = fn(x - eps, r1, a, big_r), fn(x + eps, r1, a, big_r)
        assert float(left[0]) == pytest.approx(float(right[0]), abs=1e-10)
        assert float(left[1]) == pytest.approx(0.0, abs=1e-9)
        assert float(right[1]) == pytest.approx(0.0, abs=1e-9)
        assert float(left[2]) == pytest.approx(-r / (rr * (1 + r)), rel=1e-6)
        assert float(right[2]) == pytest.approx(r / (rr * (1 - r)), rel=1e-6)
    assert float(fn(np.pi, r1, a, big_r)[0]) == pytest.approx(2 * r / rr, rel=1e-15)
    assert float(fn(2 * np.pi, r1, a, big_r)[0]) == pytest.approx(4 * r / rr, rel=1e-14)
    assert float(fn(6 * np.pi + 1.0, r1, a, big_r)[0]) == pytest.approx(
        3 * 4 * r / rr + float(fn(1.0, r1, a, big_r)[0]), rel=1e-14)


def test_position_derivatives_match_finite_differences():
    """AD through if_else against central differences inside each branch (h = 1e-5: error ~1e-10)."""
    fn = position_function()
    h = 1e-5
    for x in np.linspace(0.1, 2 * np.pi - 0.1, 37):
        if abs(x - np.pi) < 2 * h:
            continue
        v = [float(fn(x + s * h, 5.0, 50.0, 250.0)[0]) for s in (-1, 0, 1)]
        out = fn(x, 5.0, 50.0, 250.0)
        assert float(out[1]) == pytest.approx((v[2] - v[0]) / (2 * h), abs=1e-10)
        assert float(out[2]) == pytest.approx((v[2] - 2 * v[1] + v[0]) / h**2, abs=1e-5)


def test_breakpoints_are_the_dead_centres():
    mech = get_mechanism("pulse_reducer")
    assert mech.breakpoints(PAPER, 2) == pytest.approx((0.0, math.pi))
    assert mech.breakpoints(PAPER, 3) == pytest.approx(tuple(k * math.pi / 3 for k in range(6)))


@pytest.mark.parametrize("n", [1, 2, 3, 5])
def test_exact_agrees_with_a_very_fine_grid(n):
    """Exact figures against 4·10⁵ samples. The grid never passes the exact extremes; it misses
    a smooth maximum by O(h²) and a kink (the minimum at a hand-over) by up to h·|slope|."""
    d = design(freewheels=n, a=20.0)
    f, _ = exact_figures(d, "forward", W1)
    phi = np.linspace(0, 2 * np.pi, 400_000, endpoint=False)
    out = d.sample(phi)
    env = np.maximum(out["dtheta"].max(axis=0), 0.0) * W1
    kink = (phi[1] - phi[0]) * W1 * np.abs(out["ddtheta"]).max()
    assert env.max() <= f.omega_max * (1 + 1e-12)
    assert env.max() == pytest.approx(f.omega_max, rel=1e-9)
    assert env.min() >= f.omega_min - 1e-12
    assert env.min() == pytest.approx(f.omega_min, abs=kink)
    assert env.mean() == pytest.approx(f.omega_mean, rel=1e-10)


def test_one_freewheel_is_intermittent():
    """n = 1: one drive, output at rest for half a turn; ratio 2·r1/(2π·R1)."""
    f, _ = exact_figures(design(freewheels=1), "forward", W1)
    assert f.ratio == pytest.approx(2 * 5.0 / (2 * math.pi * 250.0), rel=1e-12)
    assert f.omega_min == 0.0


def test_design_constraint_is_r_below_one():
    mech = get_mechanism("pulse_reducer")
    p = {k: ca.SX(v) for k, v in PAPER.items() if k != "freewheels"}
    (c,) = mech.criteria(Constraints(assembly_margin=1e-3), {})
    assert c.name == "crank_inside_pivots"
    assert float(ca.evalf(c.formula(p))) == pytest.approx(1 - 0.1, rel=1e-15)
    assert c.bounds(None) == (1e-3, float("inf"))


# ------------------------------------------------------------------ problem file and CLI
def test_problem_file_holds_the_papers_values():
    problem = load_problem(PROBLEM)
    assert problem.start_values() == {"r1": 5.0, "a": 50.0, "R1": 250.0, "freewheels": 2.0}
    assert problem.input_speed == 97.0


def test_cli_analyze_json(capsys):
    assert main(["analyze", str(PROBLEM), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["assembles"] is True
    assert set(out["strokes"]) == {"forward"}        # the freewheels drive one way only
    assert out["strokes"]["forward"]["ratio"] == pytest.approx(0.0127324, abs=1e-7)
    assert out["min_transmission_angle_deg"] == 90.0  # no transmission angle: cos μ = 0
    assert out["design"]["freewheels"] == 2


def _problem(write_problem, **design_changes):
    data = yaml.safe_load(PROBLEM.read_text())
    data["design"].update(design_changes)
    return write_problem(data)


@pytest.mark.parametrize("changes, message", [
    (dict(r1=50), r"p\.yaml: design\.r1 must be shorter than a \(got r1 = 50, a = 50\)"),
    (dict(r1=60, a=50), r"eqs\. \(1\)-\(2\) need r = r1/a < 1"),
    (dict(freewheels=0), r"p\.yaml: design\.freewheels must be at least 1 \(got 0\)"),
    (dict(R1=-250), r"p\.yaml: design\.R1 must be positive \(got -250\)"),
])
def test_bad_inputs(write_problem, capsys, changes, message):
    path = _problem(write_problem, **changes)
    assert main(["analyze", str(path), "--json"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert re.search(message, err), err


def test_reverse_stroke_is_refused(write_problem, capsys):
    data = yaml.safe_load(PROBLEM.read_text()) | {"stroke": "reverse"}
    assert main(["analyze", str(write_problem(data))]) == 2
    assert "stroke must be one of forward (got 'reverse')" in capsys.readouterr().err


@settings(max_examples=15, deadline=None)
@given(r=st.floats(0.01, 0.98), r1=st.floats(1.0, 100.0), big_r1=st.floats(10.0, 1000.0))
def test_ratio_closed_form_property(r, r1, big_r1):
    """Any r < 1, any sizes: two freewheels give the ratio 4·r1/(2π·R1) (exact, rel 1e-10)."""
    f, _ = exact_figures(design(r1=r1, a=r1 / r, R1=big_r1), "forward", 1.0)
    assert f.ratio == pytest.approx(4 * r1 / (2 * math.pi * big_r1), rel=1e-10)

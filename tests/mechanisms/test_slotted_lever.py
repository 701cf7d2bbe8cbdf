"""Vergov's slotted-lever variator against the paper's eqs. (7)-(8) and its closed forms."""
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
from optdesign.mechanisms.slotted_lever import paper_speed_analogue
from optdesign.problem.loader import Constraints, load_problem
from tests.conftest import ROOT

PROBLEM = ROOT / "problems" / "vergov.yaml"
XD, L = 292.0, 74.0          # mm, the paper's case
W1 = 0.628                   # rad/s (6 rpm), the paper's ω1
PSI_MAX = math.asin(L / (2 * XD - L))    # amplitude: A on a circle of radius L/2 about (L/2, 0)


def design(sections=1, **changes):
    return Design("slotted_lever", dict(XD=XD, L=L, sections=sections) | changes)


def test_speed_analogue_is_the_papers_eq_8():
    """AD dψ/dφ against eq. (8) as printed at 3601 angles: same function, rounding only."""
    phi = np.linspace(0, 2 * np.pi, 3601)
    ad = design().sample(phi)["dtheta"][0]
    assert np.max(np.abs(ad - paper_speed_analogue(phi, XD, L))) < 1e-14


def test_position_is_eq_7():
    phi = np.linspace(0, 2 * np.pi, 721)
    psi = design().sample(phi)["theta"][0]
    eq7 = np.arctan(L * np.sin(phi) * np.cos(phi) / (XD - L * np.cos(phi) ** 2))
    assert np.max(np.abs(psi - eq7)) < 1e-15


def test_acceleration_analogue_matches_differences_of_eq_8():
    """d²ψ/dφ² by AD against a central difference of eq. (8) (h = 1e-6: error ~1e-9)."""
    h = 1e-6
    phi = np.linspace(0.05, 2 * np.pi, 97)
    ad = design().sample(phi)["ddtheta"][0]
    fd = (paper_speed_analogue(phi + h, XD, L) - paper_speed_analogue(phi - h, XD, L)) / (2 * h)
    assert np.max(np.abs(ad - fd)) < 1e-8


def test_symmetry():
    """ψ is odd in φ and has period π (A circles twice per turn); ψ' is even."""
    phi = np.linspace(0, np.pi, 181)
    s = lambda x: design().sample(x)                                       # noqa: E731
    assert np.allclose(s(-phi)["theta"], -s(phi)["theta"], atol=1e-15)
    assert np.allclose(s(phi + np.pi)["theta"], s(phi)["theta"], atol=1e-14)
    assert np.allclose(s(-phi)["dtheta"], s(phi)["dtheta"], atol=1e-15)


def test_closed_form_extremes_and_ratio():
    """Amplitude asin(L/(2XD - L)) = 8.343°; Aω7 = L/(XD - L) at φ = 0 and -L/XD at φ = π/2;
    forward and reverse each collect 2·2ψ_max per turn, ``both`` twice that. One section: the
    output stops at the turning points (ω_min = 0, δ = 2). Exact evaluator: rel 1e-12."""
    forward, _ = exact_figures(design(), "forward", W1)
    reverse, _ = exact_figures(design(), "reverse", W1)
    both, _ = exact_figures(design(), "both", W1)
    assert forward.omega_max == pytest.approx(W1 * L / (XD - L), rel=1e-12)     # 0.21317 rad/s
    assert reverse.omega_max == pytest.approx(W1 * L / XD, rel=1e-12)           # 0.15915 rad/s
    assert both.omega_max == pytest.approx(forward.omega_max, rel=1e-12)
    assert forward.ratio == pytest.approx(4 * PSI_MAX / (2 * math.pi), rel=1e-12)   # 0.09270
    assert reverse.ratio == pytest.approx(forward.ratio, rel=1e-12)
    assert both.ratio == pytest.approx(8 * PSI_MAX / (2 * math.pi), rel=1e-12)      # 0.18540
    for f in (forward, reverse, both):
        assert f.omega_min == pytest.approx(0.0, abs=1e-15)
        assert f.delta == pytest.approx(2.0, rel=1e-12)


def test_regulating_L_lowers_the_ratio():
    """The eccentricity fraction e scales L (the paper: changing L changes the ratio)."""
    half, _ = exact_figures(design(), "both", W1, eccentricity=0.5)
    assert half.ratio == pytest.approx(8 * math.asin(37 / (2 * XD - 37)) / (2 * math.pi),
                                       rel=1e-12)


def test_scale_invariance():
    """Lengths in other units: δ and the ratio do not change."""
    f, _ = exact_figures(design(sections=3), "both", W1)
    g, _ = exact_figures(design(sections=3).scaled(25.4), "both", W1)
    assert g.delta == pytest.approx(f.delta, rel=1e-10)
    assert g.ratio == pytest.approx(f.ratio, rel=1e-10)


def test_sections_are_shifted_by_pi_over_n():
    """Two sections a quarter of a turn apart (not 2π/2 = π, which would put them in phase)."""
    phi = np.linspace(0, 2 * np.pi, 73)
    theta = design(sections=2).sample(phi)["theta"]
    assert np.allclose(theta[1], design().sample(phi - np.pi / 2)["theta"][0], atol=1e-15)
    assert not np.allclose(theta[0], theta[1])


def test_more_sections_smooth_the_output():
    """δ of the stroke ``both`` for 1..4 sections (our computation, pinned to 1e-4): it falls
    from 2 to 0.343 at n = 3, but rises again at n = 4, where the reverse strokes fall on the
    same phases as the forward ones (docs/mechanisms.md)."""
    deltas = [exact_figures(design(sections=n), "both", W1)[0].delta for n in (1, 2, 3, 4)]
    assert deltas == pytest.approx([2.0, 1.5667, 0.3429, 0.5092], abs=1e-4)


@pytest.mark.parametrize("stroke", ["forward", "reverse", "both"])
@pytest.mark.parametrize("n", [1, 2, 3])
def test_exact_agrees_with_a_very_fine_grid(stroke, n):
    """Exact figures against 4·10⁵ samples: the grid never passes the exact extremes, misses a
    kink by at most h·|slope|, and its mean agrees to ~1e-10 (smooth periodic integrand)."""
    d = design(sections=n)
    f, _ = exact_figures(d, stroke, W1)
    phi = np.linspace(0, 2 * np.pi, 400_000, endpoint=False)
    out = d.sample(phi)
    signs = {"forward": (1,), "reverse": (-1,), "both": (1, -1)}[stroke]
    env = np.maximum(np.vstack([s * out["dtheta"] for s in signs]).max(axis=0), 0.0) * W1
    kink = (phi[1] - phi[0]) * W1 * np.abs(out["ddtheta"]).max()
    assert env.max() <= f.omega_max * (1 + 1e-12)
    assert env.max() == pytest.approx(f.omega_max, rel=1e-8)
    assert env.min() >= f.omega_min - 1e-15
    assert env.min() == pytest.approx(f.omega_min, abs=kink)
    assert env.mean() == pytest.approx(f.omega_mean, rel=1e-9)


def test_design_constraint_is_XD_beyond_L():
    mech = get_mechanism("slotted_lever")
    (c,) = mech.criteria(Constraints(assembly_margin=1e-3), {})
    assert c.name == "pivot_outside_circle"
    g = c.formula({"XD": ca.SX(XD), "L": ca.SX(L)})
    assert float(ca.evalf(g)) == pytest.approx(1 - L / XD)
    assert c.bounds(None) == (1e-3, float("inf"))
    assert c.formula({"XD": XD, "L": L}) == pytest.approx(1 - L / XD)   # the same formula


# ------------------------------------------------------------------ problem file and CLI
def test_problem_file_holds_the_papers_values():
    problem = load_problem(PROBLEM)
    assert problem.start_values() == {"XD": 292.0, "L": 74.0, "sections": 1.0}
    assert problem.input_speed == 0.628
    assert problem.stroke == "both"


def test_cli_analyze_json(capsys):
    assert main(["analyze", str(PROBLEM), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["assembles"] is True
    assert set(out["strokes"]) == {"forward", "reverse", "both"}
    assert out["strokes"]["both"]["ratio"] == pytest.approx(0.185399, abs=1e-6)
    assert out["strokes"]["forward"]["omega_max"] == pytest.approx(0.213174, abs=1e-6)
    assert out["min_transmission_angle_deg"] == 90.0
    assert [r["eccentricity"] for r in out["regulation"]] == [1.0, 0.5]


def _problem(write_problem, stroke=None, **design_changes):
    data = yaml.safe_load(PROBLEM.read_text())
    data["design"].update(design_changes)
    if stroke:
        data["stroke"] = stroke
    return write_problem(data)


@pytest.mark.parametrize("changes, message", [
    (dict(XD=74), r"p\.yaml: design\.XD must exceed L \(got XD = 74, L = 74\): the "
                  r"kulisa-crank 7 would turn round"),
    (dict(L=300), r"eq\. 7 needs XD > L"),
    (dict(sections=0), r"p\.yaml: design\.sections must be at least 1 \(got 0\)"),
    (dict(sections=1.5), r"p\.yaml: design\.sections must be a whole number \(got 1\.5\)"),
    (dict(L=0), r"p\.yaml: design\.L must be positive \(got 0\)"),
    (dict(stroke="sideways"), r"p\.yaml: stroke must be one of forward, reverse, both "
                              r"\(got 'sideways'\)"),
])
def test_bad_inputs(write_problem, capsys, changes, message):
    path = _problem(write_problem, **changes)
    assert main(["analyze", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert re.search(message, err), err


@settings(max_examples=15, deadline=None)
@given(xd=st.floats(100.0, 1000.0), fraction=st.floats(0.02, 0.9))
def test_ratio_closed_form_property(xd, fraction):
    """Any XD > L: stroke ``both`` collects 8·asin(L/(2XD - L)) per turn (exact, rel 1e-10)."""
    big_l = fraction * xd
    f, _ = exact_figures(design(XD=xd, L=big_l), "both", 1.0)
    assert f.ratio == pytest.approx(8 * math.asin(big_l / (2 * xd - big_l)) / (2 * math.pi),
                                    rel=1e-10)

"""The flexible cardan shaft (Vestnik DGTU 2017, no. 2(89), eqs. 6-18) and its ``driveline:`` section."""
from __future__ import annotations

import copy
import json
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from optdesign.cli import main
from optdesign.driveline import model
from optdesign.driveline.section import DrivelineSection
from optdesign.errors import ProblemError
from optdesign.problem.loader import load_problem, problem_from_dict

ROOT = Path(__file__).resolve().parents[1]
PROBLEM = ROOT / "problems" / "driveline.yaml"
BASE = yaml.safe_load(PROBLEM.read_text())

# A steel tube, SI: 1.4 m between supports, 75 x 2 mm tube.
L, A_PLANE, C_PLANE = 1.4, 0.1, 0.15
AREA, SECOND_MOMENT = model.tube_section(0.075, 0.002)
M_PRIME = 7850.0 * AREA
EI = 210e9 * SECOND_MOMENT
MASS = M_PRIME * L
W_CR = model.first_critical_speed(L, EI, M_PRIME)
Y0 = model.initial_deflection(L, 0.4)


def load(data: dict, where: str = "driveline.yaml"):
    return problem_from_dict(data, where=where)


def with_driveline(**changes) -> dict:
    data = copy.deepcopy(BASE)
    for key, value in changes.items():
        if value is None:
            data["driveline"].pop(key, None)
        else:
            data["driveline"][key] = value
    return data


# --------------------------------------------------------------------------- the formulas
def test_tube_section_closed_form():
    # 75 x 2 mm tube: d = 71 mm; exact to rounding.
    assert AREA == pytest.approx(math.pi / 4 * (0.075**2 - 0.071**2), rel=1e-14)
    assert SECOND_MOMENT == pytest.approx(math.pi / 64 * (0.075**4 - 0.071**4), rel=1e-14)


def test_first_critical_speed_closed_form_of_simply_supported_tube():
    # ω_cr = (π/L)²·sqrt(EI/m') for a pinned-pinned uniform beam; equivalently the first
    # natural frequency f1 = (π/(2L²))·sqrt(EI/m') Hz. Same formula, independent spelling.
    f1 = math.pi / (2 * L**2) * math.sqrt(EI / M_PRIME)
    assert W_CR == pytest.approx(2 * math.pi * f1, rel=1e-12)
    assert model.beta(W_CR) == pytest.approx(MASS * L**3 / (math.pi**4 * EI), rel=1e-12)


def test_first_critical_speed_matches_a_finite_difference_beam():
    # EI·w'''' = m'·ω²·w, w = w'' = 0 at both ends: the lowest eigenvalue of the central
    # difference operator (D2)² converges as O(h²); 400 cells give about 1e-5 relative.
    n = 400
    h = L / n
    d2 = (np.diag(-2.0 * np.ones(n - 1)) + np.diag(np.ones(n - 2), 1)
          + np.diag(np.ones(n - 2), -1)) / h**2
    lam = np.linalg.eigvalsh(d2 @ d2).min()
    assert math.sqrt(EI / M_PRIME * lam) == pytest.approx(W_CR, rel=1e-4)


def test_critical_speed_of_the_worked_car_shaft_example():
    # calcady.com driveshaft critical speed: 45 in, 3.5 x 0.083 in steel, 30 Mpsi,
    # 0.283 lb/in³ -> 11,390 rpm. Their intermediate values are rounded to 4 digits, so 0.2 %.
    area, second_moment = model.tube_section(3.5 * 0.0254, 0.083 * 0.0254)
    w = model.first_critical_speed(45 * 0.0254, 30e6 * 6894.757 * second_moment,
                                   0.283 * 27679.9 * area)
    assert w * 30 / math.pi == pytest.approx(11390, rel=2e-3)


@pytest.mark.parametrize("fraction", [0.0, 0.1, 0.3, 0.5, 0.7, 0.9, 0.99])
def test_amplification_is_one_over_one_minus_beta_omega_squared(fraction):
    omega = fraction * W_CR
    expected = 1.0 / (1.0 - model.beta(W_CR) * omega**2)
    assert model.amplification(omega, W_CR) == pytest.approx(expected, rel=1e-12)
    assert model.deflection(omega, W_CR, Y0) == pytest.approx(Y0 * expected, rel=1e-12)
    # eq. 12 + eq. 9: y_max = y0 + Δy, Δy = y0·βω²/(1 - βω²)
    beta_w2 = model.beta(W_CR) * omega**2
    assert model.deflection(omega, W_CR, Y0) == pytest.approx(Y0 + Y0 * beta_w2 / (1 - beta_w2),
                                                              rel=1e-12)


def test_amplification_is_finite_and_accurate_just_below_critical():
    # r = 1 - 1e-12: 1/(1 - r²) = 1/((1 - r)(1 + r)) ≈ 5e11; r itself carries ~1e-16 of
    # rounding, so 1 - r is known to about 1e-4 relative.
    omega = W_CR * (1 - 1e-12)
    amp = model.amplification(omega, W_CR)
    assert np.isfinite(amp) and amp == pytest.approx(0.5e12, rel=1e-3)
    d0 = model.principal_imbalance(MASS, model.deflection(omega, W_CR, Y0))
    assert np.isfinite(d0) and d0 > 0


@pytest.mark.parametrize("fraction", [1.0, 1.0 + 1e-12, 1.5, 10.0])
def test_at_or_above_critical_raises_never_negative_or_infinite(fraction):
    with pytest.raises(ProblemError, match=r"at or above the first critical speed"):
        model.amplification(fraction * W_CR, W_CR)
    with pytest.raises(ProblemError, match=r"at or above the first critical speed"):
        model.corrections_balanced_at(fraction * W_CR, W_CR, MASS, EI, Y0, L, A_PLANE, C_PLANE)


def test_principal_imbalance_is_five_eighths_m_y():
    assert model.principal_imbalance(MASS, Y0) == pytest.approx(5 / 8 * MASS * Y0, rel=1e-15)


def test_plane_shares_sum_to_one_and_balance_the_moment():
    s1, s2 = model.plane_shares(L, A_PLANE, C_PLANE)
    assert s1 + s2 == pytest.approx(1.0, rel=1e-14)
    # moments about the mid-span plane cancel: s1·(0.5l - A) = s2·(0.5l - C)
    assert s1 * (0.5 * L - A_PLANE) == pytest.approx(s2 * (0.5 * L - C_PLANE), rel=1e-14)


def _midspan_deflection_of_point_load(F, a):
    """Pinned-pinned beam, load F at a from the left: deflection at x = l/2 (Roark/Gere).

    For x <= a: y = F·(l - a)·x·(l² - (l - a)² - x²)/(6·l·EI); mirror when a < l/2.
    """
    if a < 0.5 * L:
        a = L - a
    b, x = L - a, 0.5 * L
    return F * b * x * (L**2 - b**2 - x**2) / (6 * L * EI)


@pytest.mark.parametrize("fraction", [0.05, 0.4, 0.8])
def test_b_is_the_bend_the_correcting_forces_take_away(fraction):
    # Independent of eq. 17's algebra: load the beam with the centrifugal forces ω²·Dk of
    # corrections X·s1 at x = A and X·s2 at x = l - C, take the mid-span deflection from the
    # textbook point-load formula, and D0's change (5/8)·m·Δy must be b·X.
    omega = fraction * W_CR
    s1, s2 = model.plane_shares(L, A_PLANE, C_PLANE)
    X = 1.0
    dy = (_midspan_deflection_of_point_load(omega**2 * X * s1, A_PLANE)
          + _midspan_deflection_of_point_load(omega**2 * X * s2, L - C_PLANE))
    b = model.coefficient_b(omega, MASS, EI, L, A_PLANE, C_PLANE)
    assert 5 / 8 * MASS * dy == pytest.approx(b * X, rel=1e-12)


def test_b_and_corrections_tend_to_static_values_as_speed_falls():
    static = model.corrections_static(model.principal_imbalance(MASS, Y0), L, A_PLANE, C_PLANE)
    previous = None
    for omega in (100.0, 10.0, 1.0, 1e-3):
        b = model.coefficient_b(omega, MASS, EI, L, A_PLANE, C_PLANE)
        dk = model.corrections_balanced_at(omega, W_CR, MASS, EI, Y0, L, A_PLANE, C_PLANE)
        gap = max(abs(dk[0] - static[0]) / static[0], abs(dk[1] - static[1]) / static[1])
        if previous is not None:
            assert gap < previous[1] and b < previous[0]
        previous = (b, gap)
    assert model.coefficient_b(0.0, MASS, EI, L, A_PLANE, C_PLANE) == 0.0
    b, gap = previous
    # both go as ω²: at 1e-3 rad/s, b ~ 1e-13 and the corrections equal eq. 8 to ~1e-12
    assert b < 1e-11 and gap < 1e-10
    dk0 = model.corrections_balanced_at(0.0, W_CR, MASS, EI, Y0, L, A_PLANE, C_PLANE)
    assert dk0[0] == pytest.approx(static[0], rel=1e-15)
    assert dk0[1] == pytest.approx(static[1], rel=1e-15)
    # and the bend of eq. 18 tends to y0_max
    assert model.deflection_balanced_at(0.0, W_CR, MASS, EI, Y0, L, A_PLANE, C_PLANE) == Y0


def test_b_is_dimensionless():
    # A dimensionless group does not change when the base units change. Rewrite the shaft in
    # mm, g and ms: lengths ×1e3, mass ×1e3, ω ×1e-3 (rad/ms), EI in g·mm³/ms² (×1e3·1e9·1e-6).
    omega = 0.6 * W_CR
    si = model.coefficient_b(omega, MASS, EI, L, A_PLANE, C_PLANE)
    other = model.coefficient_b(omega * 1e-3, MASS * 1e3, EI * 1e6, L * 1e3, A_PLANE * 1e3,
                                C_PLANE * 1e3)
    assert other == pytest.approx(si, rel=1e-12)
    # and ω_cr·time unit is consistent in the same system (rad/ms)
    assert model.first_critical_speed(L * 1e3, EI * 1e6, M_PRIME) == pytest.approx(W_CR * 1e-3,
                                                                                   rel=1e-12)


def test_eq16_and_eq18_share_the_factor_one_over_one_plus_b():
    omega = 0.7 * W_CR
    b = model.coefficient_b(omega, MASS, EI, L, A_PLANE, C_PLANE)
    amp = model.amplification(omega, W_CR)
    s1, s2 = model.plane_shares(L, A_PLANE, C_PLANE)
    dk1, dk2 = model.corrections_balanced_at(omega, W_CR, MASS, EI, Y0, L, A_PLANE, C_PLANE)
    assert dk1 == pytest.approx(5 / 8 * MASS * Y0 * amp / (1 + b) * s1, rel=1e-13)
    assert dk2 == pytest.approx(5 / 8 * MASS * Y0 * amp / (1 + b) * s2, rel=1e-13)
    y = model.deflection_balanced_at(omega, W_CR, MASS, EI, Y0, L, A_PLANE, C_PLANE)
    assert y == pytest.approx(Y0 * amp / (1 + b), rel=1e-13)
    # self-consistency: the installed corrections leave D0 = X, X = D0(eq. 15) - b·X
    X = dk1 + dk2
    assert 5 / 8 * MASS * Y0 * amp - b * X == pytest.approx(X, rel=1e-12)


@pytest.mark.parametrize("name, per_metre", [("normal", 0.4), ("increased", 0.25),
                                             ("high", 0.15)])
def test_gost_5005_straightness_classes(name, per_metre):
    assert model.GOST_5005_STRAIGHTNESS_MM_PER_M[name] == per_metre
    section = load(with_driveline(straightness_class=name)).sections["driveline"]
    assert section.y0_max * 1e3 == pytest.approx(per_metre * 1.143, rel=1e-12)
    assert per_metre in (0.4, 0.25, 0.15)


def test_default_straightness_is_normal_and_y0_may_be_given():
    section = load(with_driveline(straightness_class=None)).sections["driveline"]
    assert section.y0_max == pytest.approx(0.4e-3 * 1.143, rel=1e-12)
    section = load(with_driveline(straightness_class=None, y0_max_mm=0.3)).sections["driveline"]
    assert section.y0_max == pytest.approx(0.3e-3) and section.y0_source == "given"


def test_direct_stiffness_equals_the_tube():
    tube = load(BASE).sections["driveline"]
    data = with_driveline(outer_diameter_mm=None, wall_mm=None, youngs_modulus_gpa=None,
                          density_kg_m3=None, mass_per_length_kg_m=tube.mass_per_length,
                          EI_n_m2=tube.EI)
    direct = load(data).sections["driveline"]
    assert direct.critical_speed == pytest.approx(tube.critical_speed, rel=1e-14)


# --------------------------------------------------------------------------- the section
def test_car_shaft_figures():
    # problems/driveline.yaml: 11,379 rpm from the closed form (see the worked example above)
    problem = load_problem(PROBLEM)
    section = problem.sections["driveline"]
    assert section.critical_speed == pytest.approx(1191.46, abs=0.01)
    f = section.figures(0.5 * section.critical_speed)
    assert f["amplification"] == pytest.approx(4 / 3, rel=1e-12)
    assert f["y_max_mm"] == pytest.approx(4 / 3 * 0.4572, rel=1e-12)
    assert f["D0_g_mm"] == pytest.approx(5 / 8 * section.mass * f["y_max_mm"] * 1e3, rel=1e-12)
    # symmetric planes A = C: equal corrections
    assert f["Dk1_g_mm"] == pytest.approx(f["Dk2_g_mm"], rel=1e-14)
    assert 0 < f["y_max_balanced_mm"] < f["y_max_mm"]


def test_figures_just_below_critical_are_finite_and_positive():
    section = load_problem(PROBLEM).sections["driveline"]
    f = section.figures(section.critical_speed * (1 - 1e-9))
    numbers = [v for v in f.values() if isinstance(v, float)]
    assert all(np.isfinite(v) and v >= 0 for v in numbers)
    assert f["amplification"] == pytest.approx(0.5e9, rel=1e-5)


def test_solve_constraints_with_a_casadi_symbol():
    import casadi as ca

    problem = load_problem(PROBLEM)
    section = problem.sections["driveline"]
    w = ca.SX.sym("omega_out_max")
    (name, g), = section.solve_constraints(problem, w)
    assert name == "driveline_max_speed_fraction_of_critical"
    f = ca.Function("g", [w], [g])
    w_cr = section.critical_speed
    # g = 0.7 - ω/ω_cr (speed_factor 1): >= 0 exactly up to 0.7·ω_cr
    for omega, expected in ((0.0, 0.7), (0.5 * w_cr, 0.2), (0.7 * w_cr, 0.0), (w_cr, -0.3)):
        assert float(f(omega)) == pytest.approx(expected, abs=1e-12)
    dg = ca.Function("dg", [w], [ca.jacobian(g, w)])
    assert float(dg(1.0)) == pytest.approx(-1.0 / w_cr, rel=1e-12)


def test_solve_constraints_scale_with_speed_factor_and_vanish_without_the_key():
    import casadi as ca

    problem = load(with_driveline(speed_factor=3.0))
    section = problem.sections["driveline"]
    w = ca.SX.sym("w")
    (_, g), = section.solve_constraints(problem, w)
    omega = 0.2 * section.critical_speed
    assert float(ca.Function("g", [w], [g])(omega)) == pytest.approx(0.7 - 0.6, abs=1e-12)
    data = copy.deepcopy(BASE)
    del data["constraints"]["max_speed_fraction_of_critical"]
    problem = load(data)
    assert problem.sections["driveline"].solve_constraints(problem, w) == []
    problem = load(with_driveline(speed_factor=None, operating_speed_rad_s=100.0))
    assert problem.sections["driveline"].solve_constraints(problem, w) == []


def test_verify():
    from optdesign.analyses.analyze import analyze

    problem = load_problem(PROBLEM)
    result = analyze(problem)
    section = problem.sections["driveline"]
    assert section.verify(problem, result) is None
    # 25 × 39.84 rad/s ≈ 996 rad/s > 0.7 ω_cr = 834 rad/s, still below ω_cr
    fast = load(with_driveline(speed_factor=25.0))
    message = fast.sections["driveline"].verify(fast, analyze(fast))
    assert re.fullmatch(r"driveline: the shaft turns at 995\.\d+ rad/s, 0\.83\d+ of its critical "
                        r"speed 1191\.\d+ rad/s, above max_speed_fraction_of_critical = 0\.7",
                        message)
    # past ω_cr: verify reports, it does not raise
    faster = load(with_driveline(speed_factor=40.0))
    assert "above max_speed_fraction_of_critical" in \
        faster.sections["driveline"].verify(faster, result)


def test_analyze_reports_the_constraint():
    from optdesign.analyses.analyze import analyze

    problem = load_problem(PROBLEM)
    out = analyze(problem).to_dict()["driveline"]
    assert out["operating_speed_rad_s"] == pytest.approx(39.838, abs=1e-3)   # forward ω_max
    assert out["operating_speed_source"] == "1 x forward omega_max"
    assert out["speed_limit_rad_s"] == pytest.approx(0.7 * out["critical_speed_rad_s"])
    assert out["speed_constraint_holds"] is True


# --------------------------------------------------------------------------- errors
ERRORS = [
    (dict(length_mm=-3), r"driveline\.yaml: driveline\.length_mm must be positive \(got -3\)"),
    (dict(length_mm=None), r"driveline\.yaml: driveline\.length_mm is required"),
    (dict(length_mm="long"), r"driveline\.yaml: driveline\.length_mm must be a number"),
    (dict(A_mm=None), r"driveline\.yaml: driveline\.A_mm is required \(correction plane"),
    (dict(C_mm=-1), r"driveline\.yaml: driveline\.C_mm must not be negative \(got -1\)"),
    (dict(A_mm=600), r"driveline\.yaml: driveline\.A_mm must be less than half of length_mm, "
                     r"571\.5 \(got 600\)"),
    (dict(outer_diameter_mm=None), r"driveline\.yaml: driveline\.outer_diameter_mm is required "
                                   r"\(or give mass_per_length_kg_m and EI_n_m2\)"),
    (dict(wall_mm=50), r"driveline\.yaml: driveline\.wall_mm must not exceed half of "
                       r"outer_diameter_mm, 44\.45 \(got 50\)"),
    (dict(youngs_modulus_gpa=0), r"driveline\.yaml: driveline\.youngs_modulus_gpa must be "
                                 r"positive \(got 0\)"),
    (dict(density_kg_m3=-1), r"driveline\.yaml: driveline\.density_kg_m3 must be positive"),
    (dict(EI_n_m2=1e5), r"driveline\.yaml: driveline\.EI_n_m2 cannot be given with "
                        r"outer_diameter_mm: give the tube"),
    (dict(straightness_class="perfect"), r"driveline\.yaml: driveline\.straightness_class must "
                                         r"be one of normal, increased, high \(got 'perfect'\)"),
    (dict(straightness_class=3), r"driveline\.yaml: driveline\.straightness_class must be text"),
    (dict(y0_max_mm=0.3), r"driveline\.yaml: driveline\.y0_max_mm cannot be given with "
                          r"straightness_class; give one"),
    (dict(straightness_class=None, y0_max_mm=0), r"driveline\.yaml: driveline\.y0_max_mm must "
                                                 r"be positive"),
    (dict(balancing_speed_rad_s=-1), r"driveline\.yaml: driveline\.balancing_speed_rad_s must "
                                     r"not be negative \(got -1\)"),
    (dict(balancing_speed_rad_s=1200), r"driveline\.yaml: driveline\.balancing_speed_rad_s must "
                                       r"be below the first critical speed 1191\.46 rad/s "
                                       r"\(got 1200\)"),
    (dict(speed_factor=None, operating_speed_rad_s=1191.5),
     r"driveline\.yaml: driveline\.operating_speed_rad_s must be below the first critical "
     r"speed 1191\.46 rad/s \(got 1191\.5\)"),
    (dict(operating_speed_rad_s=100), r"driveline\.yaml: driveline\.speed_factor applies only "
                                      r"when operating_speed_rad_s is not given"),
    (dict(speed_factor=0), r"driveline\.yaml: driveline\.speed_factor must be positive"),
    (dict(color="red"), r"driveline\.yaml: driveline\.color is not a known key; known: A_mm"),
]


@pytest.mark.parametrize("changes, message", ERRORS)
def test_every_section_error_names_file_and_key(changes, message):
    with pytest.raises(ProblemError, match=f"^{message}"):
        load(with_driveline(**changes))


def test_section_must_be_a_mapping():
    data = copy.deepcopy(BASE)
    data["driveline"] = [1, 2]
    with pytest.raises(ProblemError, match=r"^driveline\.yaml: driveline must be a mapping "
                                           r"\(got list\)$"):
        load(data)


def test_direct_stiffness_needs_both_keys():
    data = with_driveline(outer_diameter_mm=None, wall_mm=None, youngs_modulus_gpa=None,
                          density_kg_m3=None, mass_per_length_kg_m=4.5)
    with pytest.raises(ProblemError, match=r"^driveline\.yaml: driveline\.EI_n_m2 is required "
                                           r"with mass_per_length_kg_m$"):
        load(data)


@pytest.mark.parametrize("value, message", [
    (0.0, r"must lie in \(0, 1\) \(got 0\)"),
    (1.0, r"must lie in \(0, 1\) \(got 1\)"),
    (-0.5, r"must lie in \(0, 1\) \(got -0\.5\)"),
    ("most", r"must be a number in \(0, 1\) \(got 'most'\)"),
    (True, r"must be a number in \(0, 1\) \(got True\)"),
])
def test_constraint_value_errors(value, message):
    data = copy.deepcopy(BASE)
    data["constraints"]["max_speed_fraction_of_critical"] = value
    with pytest.raises(ProblemError, match=r"^driveline\.yaml: constraints\."
                                           r"max_speed_fraction_of_critical " + message):
        load(data)


def test_constraint_without_driveline_section():
    data = copy.deepcopy(BASE)
    del data["driveline"]
    with pytest.raises(ProblemError, match=r"^driveline\.yaml: constraints\."
                                           r"max_speed_fraction_of_critical needs a driveline: "
                                           r"section$"):
        load(data)


def test_constraint_that_no_design_can_meet():
    data = with_driveline(speed_factor=None, operating_speed_rad_s=900.0)
    with pytest.raises(ProblemError, match=r"^driveline\.yaml: constraints\."
                                           r"max_speed_fraction_of_critical = 0\.7 allows at most "
                                           r"834\.0\d+ rad/s, below driveline\."
                                           r"operating_speed_rad_s = 900, whatever the design$"):
        load(data)


def _long_shaft(tmp_path) -> Path:
    # ω_cr = (π/5)²·sqrt(1000/10) ≈ 3.95 rad/s, below the design's 39.8 rad/s output speed
    data = with_driveline(length_mm=5000, outer_diameter_mm=None, wall_mm=None,
                          youngs_modulus_gpa=None, density_kg_m3=None, mass_per_length_kg_m=10,
                          EI_n_m2=1000, balancing_speed_rad_s=None)
    del data["constraints"]["max_speed_fraction_of_critical"]
    path = tmp_path / "driveline.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_default_speed_past_critical_is_a_one_line_error(tmp_path, capsys):
    path = _long_shaft(tmp_path)
    assert main(["analyze", str(path), "--json"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert re.fullmatch(r"optdesign: driveline\.yaml: driveline\.operating_speed_rad_s \(default "
                        r"1 x forward omega_max = 39\.8383 rad/s\) must be below the first "
                        r"critical speed 3\.94784 rad/s; shorten the shaft, widen the tube or "
                        r"lower the speed\n", err)


# --------------------------------------------------------------------------- the CLI
KEYS = {"critical_speed_rad_s", "operating_speed_rad_s", "amplification", "y_max_mm", "D0_g_mm",
        "b", "Dk1_g_mm", "Dk2_g_mm", "y_max_balanced_mm", "Dk1_low_speed_g_mm",
        "Dk2_low_speed_g_mm", "y0_max_mm", "beta_s2"}


def test_cli_analyze_json_has_the_driveline_object(capsys):
    assert main(["analyze", str(PROBLEM), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert KEYS <= set(out["driveline"])
    assert out["strokes"]["forward"]["omega_max"] == pytest.approx(39.84, abs=0.01)
    d = out["driveline"]
    assert d["amplification"] == pytest.approx(1 / (1 - (d["operating_speed_rad_s"]
                                                         / d["critical_speed_rad_s"]) ** 2))


def test_analyze_without_driveline_imports_nothing_of_it():
    code = ("import json, sys, io, contextlib\n"
            "from optdesign.cli import main\n"
            "buf = io.StringIO()\n"
            "with contextlib.redirect_stdout(buf):\n"
            "    code = main(['analyze', 'problems/sharkov2022.yaml', '--json'])\n"
            "out = json.loads(buf.getvalue())\n"
            "print(json.dumps({'code': code, 'has_key': 'driveline' in out,\n"
            "  'modules': [m for m in sys.modules if m.startswith('optdesign.driveline')\n"
            "              or m.startswith('matplotlib')]}))\n")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    run = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True,
                         text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    report = json.loads(run.stdout)
    assert report == {"code": 0, "has_key": False, "modules": []}


def test_driveline_command_writes_the_figure(tmp_path, capsys):
    assert main(["driveline", str(PROBLEM), "--out", str(tmp_path)]) == 0
    png = tmp_path / "driveline.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # no temp file left; the record of the problem file beside the figure
    assert sorted(p.name for p in tmp_path.iterdir()) == [".optdesign-source.json",
                                                          "driveline.png"]
    out = capsys.readouterr().out
    assert "ω_cr = 1191.46 rad/s" in out and out.endswith(f"wrote {png}\n")


def test_driveline_command_needs_the_section(capsys):
    assert main(["driveline", str(ROOT / "problems" / "sharkov2022.yaml")]) == 2
    assert capsys.readouterr().err == ("optdesign: sharkov2022.yaml: driveline is required by "
                                       "this command (add a driveline: section)\n")


def test_plot_on_a_given_axis_reaches_0_95_of_critical():
    from matplotlib.figure import Figure

    from optdesign.driveline.plot import plot_driveline

    section = load_problem(PROBLEM).sections["driveline"]
    fig = Figure()
    ax = fig.add_subplot()
    assert plot_driveline(section, ax=ax, operating_speed=100.0) is fig
    x = ax.lines[0].get_xdata()
    assert x[0] == 0.0 and x[-1] == pytest.approx(0.95 * section.critical_speed)
    y = ax.lines[0].get_ydata()
    assert y[-1] == pytest.approx(0.4572 / (1 - 0.95**2), rel=1e-12)


def test_section_is_frozen():
    section = load_problem(PROBLEM).sections["driveline"]
    assert isinstance(section, DrivelineSection)
    with pytest.raises(AttributeError):
        section.length = 2.0


def test_analyze_of_a_design_that_does_not_assemble_keeps_the_shaft_figures():
    from types import SimpleNamespace

    problem = load_problem(PROBLEM)
    section = problem.sections["driveline"]
    out = section.analyze(problem, SimpleNamespace(assembles=False, strokes={}))
    assert out["operating_speed_rad_s"] is None
    assert out["critical_speed_rad_s"] == pytest.approx(section.critical_speed)
    assert "D0_g_mm" not in out
    message = section.verify(problem, SimpleNamespace(assembles=False, strokes={}))
    assert message == "driveline: the design does not assemble, so it has no output speed"


def test_the_constraint_bounds_a_speed_in_an_ipopt_nlp():
    # The smallest NLP that uses it: push the output speed up (speed_factor 2) against the
    # constraint; IPOPT must stop where 2·ω = 0.7·ω_cr (tolerance: IPOPT's default 1e-8).
    import casadi as ca

    problem = load(with_driveline(speed_factor=2.0))
    section = problem.sections["driveline"]
    w = ca.SX.sym("w")
    (_, g), = section.solve_constraints(problem, w)
    solver = ca.nlpsol("s", "ipopt", {"x": w, "f": -w / 100.0, "g": g},
                       {"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes"})
    sol = solver(x0=10.0, lbx=0.0, lbg=0.0, ubg=ca.inf)
    assert solver.stats()["success"]
    assert float(sol["x"]) == pytest.approx(0.35 * section.critical_speed, rel=1e-6)

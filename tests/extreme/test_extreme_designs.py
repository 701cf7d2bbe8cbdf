"""Extreme designs through the library: each gives a correct finite answer or a clear error,
never NaN, inf, a hang or a traceback (the list and the behaviour of each case is in
docs/accuracy.md).

"Correct" is checked against the fine-sampled evaluator (2^14..2^16 crank samples) whose error
is O(h) at the envelope's kinks: the tolerances below are a few times that bound.
"""
import math

import numpy as np
import pytest

from optdesign.analyses.analyze import analyze, transmission_angles
from optdesign.evaluation.design import Design
from optdesign.envelope.sampled import sampled_figures
from optdesign.errors import AssemblyError, ProblemError
from optdesign.envelope.exact import exact_figures
from optdesign.problem.loader import problem_from_dict
from tests.conftest import PAPER, base_problem

W1 = 97.0
#: l3 at which the paper's design stops assembling (chain 3 folds flat at φ ≈ 282.7°):
#: found by bisection on Design.check_assembly to 1e-14 mm
L3_EDGE = 25.498594042622084


def figures(values, e=1.0, stroke="forward", options=None):
    d = Design("fourbar_converter", PAPER | values, options or {})
    d.check_assembly(e)
    fig, _ = exact_figures(d, stroke, W1, e)
    for v in fig.to_dict().values():
        assert math.isfinite(v)
    return d, fig


def agrees_with_sampled(d, fig, e=1.0, n=1 << 14, tol=2e-3):
    s = sampled_figures(d, "forward", W1, n, e)
    assert fig.delta == pytest.approx(s.delta, abs=tol)
    assert fig.ratio == pytest.approx(s.ratio, abs=tol * max(fig.ratio, 1e-300))
    assert fig.omega_max >= s.omega_max - 1e-9 * fig.omega_max     # exact >= any sample
    assert fig.omega_min <= s.omega_min + 1e-9 * fig.omega_max


@pytest.mark.parametrize("e", [1e-2, 1e-4, 1e-6])
def test_crank_to_zero_ratio_vanishes_and_ripple_converges(e):
    """Eccentricity → 0: the ratio falls linearly (ratio/e is constant to O(e²)), δ tends to a
    finite limit (0.143594 at e = 1e-6; differences between e = 1e-4 and 1e-6 below 1e-4)."""
    d, fig = figures({}, e)
    _, ref = figures({}, 1e-6)
    assert fig.ratio / e == pytest.approx(ref.ratio / 1e-6, rel=2e-2)
    assert fig.delta == pytest.approx(0.143594, abs=3e-3)
    if e <= 1e-4:
        assert abs(fig.delta - ref.delta) < 1e-4
    agrees_with_sampled(d, fig, e)


def test_near_toggle_design_is_finite_and_exact():
    """l2 = 260.99 mm: 0.01 mm short of the Grashof limit, least transmission angle ~0.96°."""
    d, fig = figures({"l2": 260.99})
    assert 0.5 < transmission_angles(d).min() < 1.5
    agrees_with_sampled(d, fig)


def test_grashof_limit_s_plus_l_equals_p_plus_q():
    """l1 + l2 = l0 + l3 (20 + 261 = 225 + 56): chain 1 folds flat once a turn (μ = 0) and
    its rocker speed jumps there. Before the toggle fix the exact evaluator was off by up to
    0.1 in δ and depended on its grid; now every grid gives the same δ to 1e-12."""
    d, fig = figures({"l2": 261.0})
    assert transmission_angles(d).min() == pytest.approx(0.0, abs=1e-3)
    coarse, _ = exact_figures(d, "forward", W1, n_grid=8)
    fine, _ = exact_figures(d, "forward", W1, n_grid=8192)
    assert coarse.delta == pytest.approx(fine.delta, abs=1e-12)
    assert fig.delta == pytest.approx(fine.delta, abs=1e-12)
    # sampled δ converges to it as O(h) near the jump: 1.1e-4 at 2^16, 2.6e-5 at 2^18 samples
    agrees_with_sampled(d, fig, n=1 << 16, tol=3e-4)


def test_crank_longer_than_rocker_is_a_clear_assembly_error():
    """l1 >= l3 (60 > 56): chain 1 is not a crank-rocker; the error names chain and angle."""
    with pytest.raises(AssemblyError, match=r"chain \d+ does not assemble at crank angle"):
        figures({"l1": 60.0})
    with pytest.raises(AssemblyError):
        figures({"l1": 56.0})


def test_crank_longer_than_frame_is_a_problem_error():
    with pytest.raises(ProblemError, match="design.l1 must be shorter than l0"):
        problem_from_dict(base_problem(design=PAPER | {"l1": 300.0}))


@pytest.mark.parametrize("values", [
    dict(l0=2e4, l2=2e4, l2_prime=1e4),              # rods 1e3 times the crank
    dict(l1=0.225),                                  # crank 1e-3 of the frame
    dict(l1=0.056),                                  # rocker 1e3 times the crank
    dict(l0=2.25e5, l2=2.25e5, l2_prime=1e5, l3=5.6e4),   # crank 1e-4 of everything else
], ids=["long-rods", "short-crank", "long-rocker", "tiny-crank"])
def test_very_long_or_short_links(values):
    d, fig = figures(values)
    assert fig.delta >= 0 and fig.ratio > 0
    agrees_with_sampled(d, fig)


def test_short_rocker_that_cannot_reach_is_a_clear_error():
    with pytest.raises(AssemblyError, match="chain 3 does not assemble"):
        figures({"l1": 0.02, "l3": 0.056, "l2": 224.95})


@pytest.mark.parametrize("n", [2, 3, 5, 8, 13, 24])
def test_phase_count_2_to_24(n):
    """δ is not monotone in n (0.376 at 6 phases, 0.397 at 8), but small for many phases;
    with 2 phases the output nearly stops (ω_min ~1 rad/s)."""
    d, fig = figures({"phases": n})
    assert fig.omega_min >= 0
    agrees_with_sampled(d, fig, n=1 << 13)
    if n >= 13:
        assert fig.delta <= 0.36


@pytest.mark.parametrize("factor", [1e-3, 1e3, 1e-6])
def test_units_metres_and_micrometres(factor):
    """Lengths in metres (×1e-3), micrometres (×1e3), and km-like scales: same δ, ratio."""
    _, ref = figures({})
    _, fig = figures({k: v * factor for k, v in PAPER.items() if k != "phases"})
    assert fig.delta == pytest.approx(ref.delta, abs=1e-12)
    assert fig.ratio == pytest.approx(ref.ratio, abs=1e-12)


@pytest.mark.parametrize("stroke", ["forward", "reverse"])
def test_mirrored_geometry(stroke):
    """branch: right is the mirror image; with the crank still turning the same way the rocker
    speeds are time-reversed, dθ'/dφ(φ) = dθ/dφ(-φ), so every figure is unchanged."""
    _, left = figures({}, stroke=stroke)
    _, right = figures({}, stroke=stroke, options={"branch": "right"})
    for k, v in vars(left).items():           # the fields (to_dict adds the old alias)
        assert getattr(right, k) == pytest.approx(v, rel=1e-11)


def test_edge_of_assembly():
    """l3 at the edge: chain 3 just folds flat (μ = 0); a hair shorter it fails between two
    samples of the 2048-point check (caught by refining the peak of |cos μ|, a fix of this
    issue: before, that design passed the check and gave δ = 0.52 for a sampled 1.06)."""
    d, fig = figures({"l3": L3_EDGE})
    assert transmission_angles(d).min() < 0.05
    agrees_with_sampled(d, fig, n=1 << 16, tol=3e-3)
    d, fig = figures({"l3": L3_EDGE + 1e-6})
    agrees_with_sampled(d, fig, n=1 << 16, tol=1e-4)
    with pytest.raises(AssemblyError, match=r"chain 3 does not assemble at crank angle 282\.7"):
        figures({"l3": L3_EDGE - 1e-6})


def test_analyze_extreme_eccentricity_is_finite():
    """The whole analysis at e = 1e-6 (through problem files, regulation section)."""
    p = problem_from_dict(base_problem(regulation={"eccentricity": [1.0, 1e-6]}))
    out = analyze(p).to_dict()
    row = out["regulation"][-1]
    assert row["eccentricity"] == 1e-6
    assert np.isfinite(list(row["strokes"]["forward"].values())).all()
    assert row["strokes"]["forward"]["ratio"] == pytest.approx(3.437e-7, rel=1e-3)

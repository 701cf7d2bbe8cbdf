"""The envelope formula on rockers whose speed is a pure sine: every figure has a closed form."""
import math

import casadi as ca
import numpy as np
import pytest

from optdesign import mechanisms
from optdesign.evaluation.design import Design
from optdesign.envelope.sampled import (STROKE_SIGNS, driving_speeds, output_envelope,
                                       sampled_figures)
from optdesign.envelope.exact import exact_figures
from optdesign.mechanisms.base import Mechanism, VariableSpec


class SineRockers(Mechanism):
    """n rockers θ_k = -(a/b)·cos(φ - (k-1)·2π/n): ω_k/ω1 = (a/b)·sin(φ - (k-1)τ)."""

    name = "test_sine_rockers"
    source = "closed form"
    variables = (VariableSpec("a", "mm", "amplitude"), VariableSpec("b", "mm", "arm"),
                 VariableSpec("phases", "-", "count", integer=True, minimum=2))
    count_variable = "phases"
    regulating_variable = "a"

    def chain_expressions(self, phi, p, count, options):
        tau = 2 * math.pi / count
        theta = [-(p["a"] / p["b"]) * ca.cos(phi - k * tau) for k in range(count)]
        return {"theta": theta, "cos_mu": [0 * phi] * count, "joints": {}, "links": []}


@pytest.fixture
def sine(monkeypatch):
    monkeypatch.setitem(mechanisms.REGISTRY, SineRockers.name, f"{__name__}:SineRockers")
    return lambda n, a=1.0, b=1.0: Design(SineRockers.name, {"a": a, "b": b, "phases": n})


@pytest.mark.parametrize("n", [2, 3, 4, 6, 9])
def test_half_sine_envelope_closed_form(sine, n):
    """Envelope of n phase-shifted half-sines: max 1, min cos(π/n), mean (n/π)·sin(π/n),
    δ_midrange = 2·tan²(π/2n). Exact evaluator to 1e-12."""
    f, runs = exact_figures(sine(n), "forward", 1.0)
    assert f.omega_max == pytest.approx(1.0, abs=1e-12)
    assert f.omega_min == pytest.approx(math.cos(math.pi / n), abs=1e-12)
    assert f.omega_mean == pytest.approx(n / math.pi * math.sin(math.pi / n), abs=1e-12)
    assert f.delta == pytest.approx(2 * math.tan(math.pi / (2 * n)) ** 2, abs=1e-12)
    assert len(runs) == n


def test_reverse_and_both_strokes_of_sines(sine):
    """A sine is antisymmetric: reverse = forward; both strokes on 3 sines = 6 half-sines."""
    fwd, _ = exact_figures(sine(3), "forward", 1.0)
    rev, _ = exact_figures(sine(3), "reverse", 1.0)
    both, _ = exact_figures(sine(3), "both", 1.0)
    assert rev.delta == pytest.approx(fwd.delta, abs=1e-12)
    assert both.delta == pytest.approx(2 * math.tan(math.pi / 12) ** 2, abs=1e-12)


def test_output_rests_when_every_freewheel_overruns(sine):
    """Two half-sines 180° apart leave no gap, but one rocker alone (n = 2 with the second
    shifted by π) touches zero: the output is max(0, ·), so ω_min = 0, never negative."""
    f, _ = exact_figures(sine(2), "forward", 1.0)
    assert f.omega_min == pytest.approx(0.0, abs=1e-12)
    env = output_envelope(np.array([[-1.0, 0.5], [-2.0, -0.1]]), "forward")
    np.testing.assert_array_equal(env, [0.0, 0.5])


def test_sampled_figures_converge_to_exact(sine):
    exact, _ = exact_figures(sine(6), "forward", 1.0)
    errors = [abs(sampled_figures(sine(6), "forward", 1.0, n).delta - exact.delta)
              for n in (97, 389, 1543)]
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] < 1e-5


def test_ratio_scales_with_eccentricity(sine):
    full, _ = exact_figures(sine(6), "forward", 1.0, eccentricity=1.0)
    half, _ = exact_figures(sine(6), "forward", 1.0, eccentricity=0.5)
    assert half.ratio == pytest.approx(0.5 * full.ratio, rel=1e-12)
    assert half.delta == pytest.approx(full.delta, rel=1e-9)


def test_a_design_evaluated_again_reuses_its_figures_and_another_does_not(sine):
    """The exact evaluator keeps the last designs' per-eccentricity figures: the same design
    (a new but equal Design) gets the very same objects back, a design that differs in one
    length, the stroke or the eccentricity is evaluated afresh, and the store stays bounded."""
    from optdesign.evaluation import figures as evaluation

    first = evaluation.evaluate(sine(4), "forward", 1.0, (1.0, 0.5))
    again = evaluation.evaluate(sine(4), "forward", 1.0, (1.0, 0.5))
    assert [a is b for a, b in zip(first.per_e, again.per_e)] == [True, True]
    other = evaluation.evaluate(sine(4, a=1.0 + 1e-9), "forward", 1.0, (1.0,))
    assert other.per_e[0] is not first.per_e[0]
    reverse = evaluation.evaluate(sine(4), "reverse", 1.0, (1.0,))
    assert reverse.per_e[0] is not first.per_e[0]
    assert evaluation.evaluate(sine(4), "forward", 1.0, (0.25,)).per_e[0].figures[
        "forward"].ratio == pytest.approx(0.25 * first.per_e[0].figures["forward"].ratio)
    for k in range(evaluation._EVALUATED_SIZE + 5):
        evaluation.evaluate(sine(4, a=1.0 + k * 1e-3), "forward", 1.0, (1.0,))
    assert len(evaluation._EVALUATED) <= evaluation._EVALUATED_SIZE


def test_driving_speeds_are_the_rocker_speeds_signed_per_stroke():
    """Forward: the rows as they are (read in place, the screening's arrays are large);
    reverse: negated; both: forward rows, then reverse rows."""
    dtheta = np.array([[0.5, -0.25, 0.0], [1.0, 2.0, -3.0]])
    assert np.array_equal(driving_speeds(dtheta, "forward"), dtheta)
    assert np.array_equal(driving_speeds(dtheta, "reverse"), -dtheta)
    assert np.array_equal(driving_speeds(dtheta, "both"), np.vstack([dtheta, -dtheta]))


def test_signed_speeds_are_the_stacked_products_to_the_bit():
    """Each sign's rows written into one array are the products a stack of them holds, to
    the bit: a NaN (a design that does not assemble) keeps its bits, a single curve is one
    row, and the dtype is the product's."""
    rng = np.random.default_rng(3)
    dtheta = rng.normal(size=(5, 7))
    dtheta[1, 2], dtheta[3, 4] = np.nan, -np.nan
    for stroke in ("reverse", "both"):
        stacked = np.vstack([s * dtheta for s in STROKE_SIGNS[stroke]])
        assert driving_speeds(dtheta, stroke).view(np.uint64).tolist() == \
            stacked.view(np.uint64).tolist()
        assert driving_speeds(dtheta[0], stroke).shape == (len(STROKE_SIGNS[stroke]), 7)
        single = dtheta.astype(np.float32)
        assert driving_speeds(single, stroke).dtype == np.float32

"""Property tests over random assembling designs: the exact evaluator agrees with a
fine-sampled one within the sampled error bound, δ >= 0, the envelope is >= every rocker, and
nothing depends on the unit of length."""
import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from optdesign.evaluation.design import Design
from optdesign.envelope.sampled import output_envelope, sampled_figures
from optdesign.errors import AssemblyError
from optdesign.envelope.exact import exact_figures

N_FINE = 1 << 13


@st.composite
def designs(draw):
    l0 = draw(st.floats(150, 400))
    values = dict(l0=l0, l1=draw(st.floats(5, 30)), l2=l0 * draw(st.floats(0.8, 1.2)),
                  l3=draw(st.floats(30, 120)), phases=draw(st.integers(3, 9)))
    values["l2_prime"] = values["l2"] * draw(st.floats(0.2, 0.7))
    d = Design("fourbar_converter", values)
    try:
        d.check_assembly(n_samples=512)
    except AssemblyError:
        assume(False)
    return d


COMMON = settings(max_examples=6, deadline=None, derandomize=True,
                  suppress_health_check=[HealthCheck.filter_too_much, HealthCheck.too_slow])


@COMMON
@given(designs())
def test_exact_agrees_with_fine_sampled(d):
    """Sampled extremes err by at most h·max|f'| at a kink (h = 2π/N), so |Δω| <= that bound;
    the exact extremes bracket every sample."""
    ex, _ = exact_figures(d, "forward", 1.0)
    s = sampled_figures(d, "forward", 1.0, N_FINE)
    phi = np.linspace(0, 2 * np.pi, N_FINE, endpoint=False)
    slope = np.abs(d.sample(phi)["ddtheta"]).max()
    bound = 2 * np.pi / N_FINE * slope
    assert ex.omega_max >= s.omega_max - 1e-12 and ex.omega_max - s.omega_max <= bound
    assert ex.omega_min <= s.omega_min + 1e-12 and s.omega_min - ex.omega_min <= bound
    assert ex.ratio == pytest.approx(s.ratio, abs=bound)
    assert ex.delta >= 0 and s.delta >= 0


@COMMON
@given(designs())
def test_envelope_is_above_every_rocker(d):
    phi = np.linspace(0, 2 * np.pi, 720, endpoint=False)
    dtheta = d.sample(phi)["dtheta"]
    env = output_envelope(dtheta, "forward")
    assert np.all(env >= dtheta - 1e-15) and np.all(env >= 0)
    ex, _ = exact_figures(d, "forward", 1.0)
    assert ex.omega_max >= dtheta.max() - 1e-12


@COMMON
@given(designs(), st.sampled_from([1e-3, 1e3, 0.0254]))
def test_independent_of_the_unit_of_length(d, factor):
    a, _ = exact_figures(d, "forward", 97.0)
    b, _ = exact_figures(d.scaled(factor), "forward", 97.0)
    assert b.delta == pytest.approx(a.delta, abs=1e-10)
    assert b.ratio == pytest.approx(a.ratio, abs=1e-10)

"""The four-bar's chains in the screening's form (``screening_expressions``: each pin's direction
AB1's unit vector turned by (i-1)τ, not cos and sin of φ2 + (i-1)τ): the model's speeds and
transmission angles to rounding, under both pin layouts and branches, with no atan2 left in the
speeds; the model itself keeps its form."""
import casadi as ca
import numpy as np
import pytest

from optdesign.mechanisms import get_mechanism

PAPER = {"l0": 225.0, "l1": 20.0, "l2": 225.0, "l2_prime": 100.0, "l3": 56.0}


def _ops(fn: ca.Function) -> set[int]:
    return {fn.instruction_id(k) for k in range(fn.n_instructions())}


@pytest.mark.parametrize("options", [(), (("pin_layout", "text"),), (("branch", "right"),)])
@pytest.mark.parametrize("count", [2, 6, 24])
def test_the_screening_speeds_are_the_models_to_rounding(count, options):
    model = get_mechanism("fourbar_converter")
    kinematics, speeds = model.kinematics(count, options), model.speeds(count, options)
    assert ca.OP_ATAN2 not in _ops(speeds)
    assert ca.OP_ATAN2 in _ops(kinematics)           # the model keeps φ2 and the angles
    rng = np.random.default_rng(count)
    for phi in rng.uniform(0.0, 2 * np.pi, 16):
        p = [PAPER[k] * f for k, f in zip(model.lengths, rng.uniform(0.97, 1.03, 5))]
        _, dtheta, _, cos_mu = (np.array(v).ravel() for v in kinematics(phi, p))
        lean_dtheta, lean_cos = (np.array(v).ravel() for v in speeds(phi, p))
        scale = np.abs(dtheta).max()
        assert np.all(np.isfinite(dtheta))
        assert np.max(np.abs(lean_dtheta - dtheta)) <= 1e-12 * scale
        assert np.max(np.abs(lean_cos - cos_mu)) <= 1e-12


def test_a_mechanism_without_a_form_of_its_own_builds_one_model():
    """The slotted lever's speeds read its model's own expressions (one symbolic model)."""
    model = get_mechanism("slotted_lever")
    assert model.symbolic(5, (), screening=True) is model.symbolic(5, ())

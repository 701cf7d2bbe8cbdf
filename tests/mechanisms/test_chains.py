"""Each chain's own function (Mechanism.chain), taken from one symbolic call of the whole
kinematics: the same instructions and the same figures, to the bit, as chain k's function
made from a call of its own."""
import casadi as ca
import numpy as np
import pytest

from optdesign.mechanisms import get_mechanism, known


def _alone(model, count, options, k):
    phi, p = ca.SX.sym("phi"), ca.SX.sym("p", len(model.lengths))
    theta, dtheta, ddtheta, cos_mu = model.kinematics(count, options).call([phi, p], True,
                                                                           False)
    return ca.Function("alone", [phi, p], [theta[k], dtheta[k], ddtheta[k], cos_mu[k],
                                           ca.jacobian(cos_mu[k], phi)])


@pytest.mark.parametrize("mechanism", known())
@pytest.mark.parametrize("count", [3, 7])
def test_every_chain_from_one_call_is_the_chain_made_alone(mechanism, count):
    model = get_mechanism(mechanism)
    options = tuple(sorted(model.default_options().items()))
    start = {k: v["initial"] if isinstance(v, dict) else v
             for k, v in model.starter["design"].items()}
    rng = np.random.default_rng(count)
    for k in range(count):
        shared, alone = model.chain(count, options, k), _alone(model, count, options, k)
        assert shared.n_instructions() == alone.n_instructions()
        for _ in range(3):
            angles = ca.DM(rng.uniform(0.0, 2 * np.pi, 9)).T
            lengths = ca.DM([start[n] * rng.uniform(0.97, 1.03) for n in model.lengths])
            for a, b in zip(shared(angles, lengths), alone(angles, lengths)):
                assert np.array_equal(np.array(a), np.array(b), equal_nan=True)

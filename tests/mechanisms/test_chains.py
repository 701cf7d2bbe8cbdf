"""Functions built on shared symbolic work, each the same instructions and the same figures,
to the bit, as one made alone: every chain's own function (Mechanism.chain), taken from one
symbolic call of the whole kinematics; the kinematics and the joints, on the one symbolic
model of a count (Mechanism.symbolic)."""
import casadi as ca
import numpy as np
import pytest

from optdesign.mechanisms import get_mechanism, known
from tests.conftest import near_starter


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
    rng = np.random.default_rng(count)
    for k in range(count):
        shared, alone = model.chain(count, options, k), _alone(model, count, options, k)
        assert shared.n_instructions() == alone.n_instructions()
        for _ in range(3):
            angles = ca.DM(rng.uniform(0.0, 2 * np.pi, 9)).T
            lengths = ca.DM(near_starter(model, rng, 0.03))
            for a, b in zip(shared(angles, lengths), alone(angles, lengths)):
                assert np.array_equal(np.array(a), np.array(b), equal_nan=True)


@pytest.mark.parametrize("mechanism", known())
def test_kinematics_and_joints_on_the_shared_model_are_those_of_a_model_of_their_own(
        mechanism):
    """Mechanism.symbolic is built once per count and shared by the kinematics, the joints
    and the quantities: the kinematics and the joints are the functions a model of their own
    gives, instruction for instruction and bit for bit."""
    model = get_mechanism(mechanism)
    options = tuple(sorted(model.default_options().items()))
    phi, pvec = ca.SX.sym("phi"), ca.SX.sym("p", len(model.lengths))
    p = {name: pvec[i] for i, name in enumerate(model.lengths)}
    own = model.chain_expressions(phi, p, 5, model.default_options())
    theta = ca.vertcat(*own["theta"])
    dtheta = ca.jacobian(theta, phi)
    kinematics = ca.Function("own", [phi, pvec], [theta, dtheta, ca.jacobian(dtheta, phi),
                                                  ca.vertcat(*own["cos_mu"])])
    joints = ca.Function("own_joints", [phi, pvec],
                         [ca.horzcat(*[own["joints"][k] for k in own["joints"]])])
    rng = np.random.default_rng(5)
    for shared, alone in ((model.kinematics(5, options), kinematics),
                          (model.joints(5, options)[0], joints)):
        assert shared.n_instructions() == alone.n_instructions()
        angles = ca.DM(rng.uniform(0.0, 2 * np.pi, 9)).T
        lengths = ca.DM(near_starter(model, rng, 0.03))
        for a, b in zip(shared.call([angles, lengths]), alone.call([angles, lengths])):
            assert np.array_equal(np.array(a), np.array(b), equal_nan=True)

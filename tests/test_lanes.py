"""NumPy lanes evaluate a CasADi SX function with the same arithmetic as CasADi's map."""
import casadi as ca
import numpy as np
import pytest

from optdesign.lanes import Lanes
from optdesign.mechanisms import get_mechanism, known


@pytest.mark.parametrize("name", known())
@pytest.mark.parametrize("count", [2, 5])
def test_lanes_equal_casadi_map_on_every_mechanism(name, count):
    model = get_mechanism(name)
    fn = model.kinematics(count, ())
    rng = np.random.default_rng(count)
    L = 700
    phi = rng.uniform(0.0, 2 * np.pi, (1, L))
    # lengths of every size around 1, some far enough off that chains fail to assemble (NaN)
    p = rng.uniform(0.3, 3.0, (len(model.lengths), L)) * 100.0
    ours = Lanes(fn)(phi, p)
    theirs = [np.array(v) for v in fn.map(L)(phi, p)]
    for a, b in zip(ours, theirs):
        assert a.shape == b.shape
        assert np.array_equal(np.isnan(a), np.isnan(b))
        ok = ~np.isnan(b)
        assert np.array_equal(a[ok], b[ok])          # the same arithmetic: bit for bit


def test_a_column_broadcasts_to_every_lane():
    x, y = ca.SX.sym("x"), ca.SX.sym("y", 2)
    fn = ca.Function("f", [x, y], [ca.vertcat(ca.atan2(y[0], x) * y[1], ca.sqrt(x), 3.0)])
    out, = Lanes(fn)(np.array([[1.0, -1.0, 4.0]]), np.array([[2.0], [5.0]]))
    assert out.shape == (3, 3)
    np.testing.assert_array_equal(out[0], np.arctan2(2.0, [1.0, -1.0, 4.0]) * 5.0)
    assert np.isnan(out[1, 1]) and out[1, 2] == 2.0
    np.testing.assert_array_equal(out[2], 3.0)


def test_instructions_without_a_lane_form_are_refused():
    x = ca.MX.sym("x", 2)
    with pytest.raises(NotImplementedError):
        Lanes(ca.Function("mx", [x], [ca.mtimes(x.T, x)]))
    s = ca.SX.sym("s", 2, 2)
    with pytest.raises(NotImplementedError):
        Lanes(ca.Function("matrix_input", [s], [ca.trace(s)]))

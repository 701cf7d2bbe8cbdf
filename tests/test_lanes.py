"""NumPy lanes evaluate a CasADi SX function with the same arithmetic as CasADi's map.

The elementary operations (+, −, ×, ÷, √) are correctly rounded on every machine, so there the
lanes equal ``map`` bit for bit. NumPy's trigonometric and exponential functions are the C
library's on some machines and its own SIMD kernels on others (AVX-512: arccos, arctan2, exp
and the like differ from glibc's in the last bit), so on the mechanisms' functions the lanes
agree with ``map`` to a few units in the last place.
"""
import casadi as ca
import numpy as np
import pytest

from optdesign.numerics import lanes as lanes_module
from optdesign.numerics.lanes import Lanes
from optdesign.mechanisms import get_mechanism, known
from tests.conftest import kept_files


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
        # the same arithmetic; elementary functions may differ from libm's in the last bit
        assert np.all(np.abs(a[ok] - b[ok]) <= 1e-12 * np.maximum(np.abs(b[ok]), 1.0))


def test_correctly_rounded_arithmetic_is_bit_identical():
    """A circle intersection in +, −, ×, ÷ and √ alone, in the order CasADi evaluates it."""
    x = ca.SX.sym("x", 5)
    a, b, r1, r2, s = x[0], x[1], x[2], x[3], x[4]
    d2 = (a * a) + (b * b)
    along = (d2 + (r1 * r1) - (r2 * r2)) / (2 * ca.sqrt(d2))
    across = ca.sqrt(ca.fmax((r1 * r1) - (along * along), 0.0)) * s
    out = ca.vertcat(along * a / ca.sqrt(d2) - across * b / ca.sqrt(d2),
                     along * b / ca.sqrt(d2) + across * a / ca.sqrt(d2),
                     1.0 / (d2 - along * along) - ca.fmin(r1, r2) * ca.fabs(across))
    fn = ca.Function("intersection", [x], [out])
    rng = np.random.default_rng(7)
    values = rng.uniform(-3.0, 3.0, (5, 5000))
    values[2:4] = np.abs(values[2:4]) + 0.5
    values[4] = np.sign(values[4])
    ours, = Lanes(fn)(values)
    theirs = np.array(fn.map(values.shape[1])(values))
    assert np.array_equal(ours, theirs, equal_nan=True)


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


def _many_lanes(model, count, L, seed):
    rng = np.random.default_rng(seed)
    phi = rng.uniform(0.0, 2 * np.pi, (1, L))
    return phi, rng.uniform(0.3, 3.0, (len(model.lengths), L)) * 100.0


@pytest.mark.parametrize("name", known())
def test_passes_shared_between_two_threads_give_the_same_values_to_the_bit(name, monkeypatch):
    """Every lane is computed on its own: cut into other passes, or the passes shared between
    two threads, the values are those of one thread, bit for bit (lengths far enough apart
    that some chains do not assemble), whatever the count of passes (odd, even, one short)."""
    import threading

    model = get_mechanism(name)
    lanes = Lanes(model.speeds(5, ()))
    started = []
    real = threading.Thread.start
    monkeypatch.setattr(threading.Thread, "start",
                        lambda self: (started.append(self.name), real(self))[1])
    for L in (3 * lanes_module.THREADED_CHUNK + 17, 2 * lanes_module.THREADED_CHUNK + 1,
              4 * lanes_module.THREADED_CHUNK):
        args = _many_lanes(model, 5, L, L)
        alone = lanes(*args)
        with lanes_module.threads(2):
            shared = lanes(*args)
        assert all(np.array_equal(a, b, equal_nan=True) for a, b in zip(alone, shared))
    assert started == ["lanes"] * 3          # one helper thread per call, and only in threads()


def test_one_thread_unless_asked_or_the_call_is_short(monkeypatch):
    import threading

    model = get_mechanism("fourbar_converter")
    lanes = Lanes(model.speeds(4, ()))
    started = []
    monkeypatch.setattr(threading.Thread, "start", lambda self: started.append(self.name))
    lanes(*_many_lanes(model, 4, 3 * lanes_module.THREADED_CHUNK, 1))      # not asked
    with lanes_module.threads(1):
        lanes(*_many_lanes(model, 4, 3 * lanes_module.THREADED_CHUNK, 1))
    with lanes_module.threads(2):
        lanes(*_many_lanes(model, 4, lanes_module.THREADED_CHUNK, 1))      # one pass
    assert started == []


def test_an_error_in_the_helper_thread_is_raised_in_the_caller(monkeypatch):
    x = ca.SX.sym("x")
    lanes = Lanes(ca.Function("f", [x], [ca.sin(x)]))
    calls = []

    def kernel(a, o):
        calls.append(1)
        if len(calls) == 2:
            raise FloatingPointError("in a pass")
        o[0][0] = np.sin(a[0][0])

    monkeypatch.setattr(lanes, "_kernel", kernel)
    with lanes_module.threads(2), pytest.raises(FloatingPointError, match="in a pass"):
        lanes(np.zeros((1, 2 * lanes_module.THREADED_CHUNK + 1)))


def _kept(where):
    return kept_files(where, "lanes-")


def _same(a, b, fn):
    rng = np.random.default_rng(5)
    phi = rng.uniform(0.0, 2 * np.pi, (1, 300))
    p = rng.uniform(0.8, 1.2, (fn.nnz_in(1), 300)) * 100.0
    return all(np.array_equal(x, y, equal_nan=True) for x, y in zip(a(phi, p), b(phi, p)))


def test_the_code_is_kept_and_a_later_process_runs_the_same_bit_for_bit(own_cache,
                                                                       monkeypatch):
    from optdesign.numerics import lanes

    fn = get_mechanism("fourbar_converter").kinematics(3, ())
    made = Lanes(fn)
    (path,) = _kept(own_cache)
    assert oct(path.stat().st_mode & 0o077) == oct(0)

    def untranslated(fn):
        raise AssertionError("translated again: the kept code was not loaded")

    monkeypatch.setattr(lanes, "_source", untranslated)
    assert _same(Lanes(fn), made, fn)


@pytest.mark.parametrize("spoil", ["garbage", "cut short", "another function's",
                                   "writable by others"])
def test_a_kept_file_not_to_be_trusted_is_ignored_and_made_anew(own_cache, spoil):
    from optdesign.numerics import lanes

    fn = get_mechanism("slotted_lever").kinematics(3, ())
    made = Lanes(fn)
    (path,) = _kept(own_cache)
    good = path.read_bytes()
    if spoil == "garbage":
        path.write_bytes(b"import os; os.system('false')\n" * 40)
    elif spoil == "cut short":
        path.write_bytes(good[:len(good) // 2])
    elif spoil == "another function's":
        other = get_mechanism("slotted_lever").kinematics(4, ())
        Lanes(other)
        foreign = next(p for p in _kept(own_cache) if p != path)
        path.write_bytes(foreign.read_bytes())
    else:
        path.chmod(0o666)
    where, digest = lanes._cache_of(fn.serialize())
    assert lanes._cached(where, digest) is None
    assert _same(Lanes(fn), made, fn)
    assert path.read_bytes() == good and path.stat().st_mode & 0o077 == 0   # made anew


def test_nothing_is_kept_when_the_cache_is_off(own_cache, monkeypatch):
    monkeypatch.setenv("OPTDESIGN_COMPILE", "off")
    Lanes(get_mechanism("pulse_reducer").kinematics(3, ()))
    assert not own_cache.exists() or _kept(own_cache) == []

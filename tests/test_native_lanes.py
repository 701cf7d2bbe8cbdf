"""The lanes' function compiled to C (optdesign.numerics.native_lanes): the NumPy lanes' values
to the bit, on one thread and two; a solve the same with and without it; a library loaded only
when it is the user's own and intact, and a function whose elementary functions NumPy computes
otherwise than the C library left on the NumPy lanes.

The libraries are built once for the module (a second or less each), by ``optdesign
warm-up``'s path: the builder process, waited for.
"""
import math
import shutil
import time

import numpy as np
import pytest

from optdesign.commands.warmup import lanes_recipes_of
from optdesign.mechanisms import get_mechanism, known
from optdesign.numerics import c_library, lanes as lanes_module, native_lanes, user_cache
from optdesign.numerics.angle_lanes import angle_lanes, lane_functions
from optdesign.numerics.lanes import Lanes
from optdesign.problem.loader import problem_from_dict
from optdesign.solver import built as kept_nlps, solve
from tests.conftest import ROOT, file_data

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="no gcc on PATH")

FUNCTIONS = [(name, what) for name in known() for what in ("kinematics", "speeds")]


def function(name: str, what: str, count: int = 6):
    return getattr(get_mechanism(name), what)(count, ())


def vergov():
    data = file_data(ROOT / "problems" / "vergov_solve.yaml", design__sections=3)
    data["solver"]["workers"] = 1
    return problem_from_dict(data)


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    """A cache folder of the user's own with the compiled lanes of :data:`FUNCTIONS` and of
    the Vergov problem's kinematics and speeds, built by warm-up's path."""
    base = tmp_path_factory.mktemp("cache")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("XDG_CACHE_HOME", str(base))
        mp.setenv(user_cache.VARIABLE, "load")
        where = user_cache.folder()
        recipes = [native_lanes.recipe(fn, fn.serialize())
                   for fn in (function(*f) for f in FUNCTIONS)]
        recipes += [native_lanes.recipe(fn, text) for name in known()
                    for fn, text in lane_functions(function(name, "kinematics"))]
        recipes += [rec for _, rec in lanes_recipes_of(vergov())]
        for rec, path, _, note in c_library.warm_up(recipes, where):
            assert path is not None, note
    return base


@pytest.fixture
def loaded(cache, monkeypatch):
    """The module's cache as the user's, libraries loaded, no build started."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(cache))
    monkeypatch.setenv(user_cache.VARIABLE, "load")
    return cache / "optdesign"


def _numpy(lanes: Lanes, *args):
    """``lanes`` on its NumPy statements alone."""
    native, lanes.native = lanes.native, None
    try:
        return lanes(*args)
    finally:
        lanes.native = native


@pytest.mark.parametrize("name,what", FUNCTIONS)
def test_compiled_lanes_give_the_numpy_lanes_values_to_the_bit(loaded, name, what):
    fn = function(name, what)
    lanes = Lanes(fn)
    if not native_lanes.eligible(set(lanes._kernel.__code__.co_names)):
        pytest.skip("NumPy's elementary functions are not the C library's on this machine")
    assert lanes.native is not None
    rng = np.random.default_rng(11)
    for count in (1, 7, 1030, 20000):
        phi = rng.uniform(0.0, 2 * np.pi, (1, count))
        # lengths of every size around 1, some far enough off that chains fail to assemble
        # (NaN, or a |cos μ| past 1 where the model clips a square root's argument)
        p = rng.uniform(0.3, 3.0, (fn.nnz_in(1), count)) * 100.0
        for args in ((phi, p), (phi, p[:, :1])):          # a column broadcasts to every lane
            for threads in (1, 2):
                with lanes_module.threads(threads):
                    ours = lanes(*args)
                for a, b in zip(ours, _numpy(lanes, *args)):
                    assert a.shape == b.shape
                    assert np.array_equal(a, b, equal_nan=True)


def test_a_lane_count_that_does_not_broadcast_is_an_error(loaded):
    lanes = Lanes(function("fourbar_converter", "speeds"))
    if lanes.native is None:
        pytest.skip("no compiled lanes on this machine")
    with pytest.raises(ValueError, match="lanes"):
        lanes(np.zeros((1, 5)), np.ones((5, 3)))


def _fingerprint(result) -> dict:
    return {"status": result.status, "delta": repr(result.delta), "design": result.design,
            "iterations": result.iterations, "quantities": repr(result.quantities),
            "starts": [[(s.ipopt_status, s.iterations, repr(s.delta), s.note)
                        for s in phase.starts] for phase in result.per_phase]}


def _fresh_lanes() -> None:
    """Every mechanism's lanes made anew (each decides at birth whether it runs compiled)."""
    for name in known():
        model = get_mechanism(name)
        model.lanes_made.cache_clear()
    kept_nlps.forget()


def test_a_solve_is_the_same_with_and_without_the_compiled_lanes(loaded, monkeypatch):
    problem = vergov()
    model = problem.model
    try:
        monkeypatch.setenv(user_cache.VARIABLE, "off")
        _fresh_lanes()
        assert model.kinematic_lanes(3, ()).native is None
        without = solve(problem)
        monkeypatch.setenv(user_cache.VARIABLE, "load")
        _fresh_lanes()
        if model.kinematic_lanes(3, ()).native is None:
            pytest.skip("no compiled lanes on this machine")
        with_them = solve(problem)
    finally:
        _fresh_lanes()
    assert with_them.status == "optimal"
    assert _fingerprint(with_them) == _fingerprint(without)


def _replace(path, data: bytes, mode: int = 0o700) -> None:
    """``path`` made anew with ``data`` (a new file: the one this process has mapped, an
    earlier test's library, is never written over, as the builder never does)."""
    fresh = path.with_name(path.name + ".new")
    fresh.write_bytes(data)
    fresh.chmod(mode)
    fresh.replace(path)


@pytest.mark.parametrize("spoil", ["corrupt", "writable", "foreign"])
def test_a_library_not_to_be_trusted_is_not_loaded(loaded, spoil):
    fn = function("fourbar_converter", "speeds")
    rec = native_lanes.recipe(fn, fn.serialize())
    path = c_library.library(rec, loaded)
    if Lanes(fn).native is None:
        pytest.skip("no compiled lanes on this machine")
    good = path.read_bytes()
    try:
        if spoil == "corrupt":
            _replace(path, good[:len(good) // 2] + good[-200:])
        elif spoil == "writable":
            _replace(path, good, 0o766)
        else:                   # another function's library under this one's name
            other = function("slotted_lever", "speeds")
            _replace(path, c_library.library(native_lanes.recipe(other, other.serialize()),
                                             loaded).read_bytes())
        lanes = Lanes(fn)
        assert lanes.native is None
        phi = np.linspace(0.0, 6.0, 50)[None, :]
        p = np.full((fn.nnz_in(1), 1), 100.0)
        assert all(np.array_equal(a, b, equal_nan=True)
                   for a, b in zip(lanes(phi, p), _numpy(Lanes(fn), phi, p)))
        assert not list(loaded.glob("*.lock"))            # under `load` no build is started
    finally:
        _replace(path, good)
    assert Lanes(fn).native is not None


def test_nothing_compiled_is_loaded_when_the_cache_is_off(loaded, monkeypatch):
    monkeypatch.setenv(user_cache.VARIABLE, "off")
    assert Lanes(function("fourbar_converter", "kinematics")).native is None


def test_a_function_numpy_computes_otherwise_stays_on_the_numpy_lanes(loaded, monkeypatch):
    """Where NumPy's sine is not the C library's (NumPy's SIMD kernels on AVX-512 machines),
    a function that takes a sine is not run compiled: its values would change."""
    monkeypatch.setitem(native_lanes.CHECKED, "sin",
                        (lambda x: math.nextafter(math.sin(x), math.inf), "wide"))
    native_lanes.agrees.cache_clear()
    try:
        fn = function("fourbar_converter", "kinematics")
        assert "sin" in Lanes(fn)._kernel.__code__.co_names
        assert not native_lanes.agrees("sin")
        assert Lanes(fn).native is None
    finally:
        native_lanes.agrees.cache_clear()
    assert not native_lanes.eligible({"np", "power"})     # NumPy's fast paths of x ** y
    assert not native_lanes.eligible({"special", "erf"})


def test_a_missing_library_is_built_beside_and_loaded_next_time(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.setenv(user_cache.VARIABLE, "on")
    fn = function("pulse_reducer", "speeds", 3)
    first = Lanes(fn)
    if not native_lanes.eligible(set(first._kernel.__code__.co_names)):
        pytest.skip("NumPy's elementary functions are not the C library's on this machine")
    assert first.native is None                           # the NumPy lanes, a build beside
    rec = native_lanes.recipe(fn, fn.serialize())
    where = user_cache.folder()
    end = time.monotonic() + 120
    while c_library.building(where, rec.name):
        assert time.monotonic() < end, "the build did not end"
        time.sleep(0.1)
    assert c_library.library(rec, where) is not None
    assert Lanes(fn).native is not None
    assert not list(where.glob("*.lock")) and not list(where.glob("*.casadi"))


def test_a_compiled_call_of_an_exact_grid_is_shared_between_two_threads(loaded, monkeypatch):
    """Compiled lanes run without the interpreter: a solve shares a call of enough work (a
    design's exact grid of the four-bar's kinematics: its last stage, after the coupler's
    angle) between its two threads, with the same values; a shorter call is not worth a
    thread's start."""
    import threading

    kinematics = angle_lanes(function("fourbar_converter", "kinematics"))
    if kinematics.native is None:
        pytest.skip("no compiled lanes on this machine")
    last = kinematics.stages[-1]
    started = []
    start = threading.Thread.start
    monkeypatch.setattr(threading.Thread, "start",
                        lambda self: (started.append(self.name), start(self))[1])
    rng = np.random.default_rng(3)
    least = -(-lanes_module.NATIVE_SHARED_WORK // last.instructions)     # lanes, rounded up
    assert least <= 1024                                    # an exact grid is shared
    assert kinematics.stages[0].instructions * 1024 < lanes_module.NATIVE_SHARED_WORK
    for count, helpers in ((least, 1), (least - 1, 0)):
        phi = rng.uniform(0.0, 2 * np.pi, (1, count))
        p = np.array([[225.0], [20.0], [225.0], [100.0], [56.0]])
        alone = kinematics(phi, p)
        assert started == []                                # not asked: one thread
        with lanes_module.threads(2):
            shared = kinematics(phi, p)
        assert started == ["lanes"] * helpers
        assert all(np.array_equal(a, b, equal_nan=True) for a, b in zip(alone, shared))
        started.clear()


def test_lanes_made_under_one_mode_are_not_given_under_another(loaded, monkeypatch):
    """A process that turns the compiled code off after making lanes is given lanes made
    under ``off`` (the NumPy lanes alone), and made under ``load`` again the compiled ones,
    as its NLPs are: lanes decide at birth whether their loop runs compiled."""
    model = vergov().model
    try:
        monkeypatch.setenv(user_cache.VARIABLE, "load")
        _fresh_lanes()
        compiled = model.kinematic_lanes(3, ())
        if compiled.native is None:
            pytest.skip("no compiled lanes on this machine")
        monkeypatch.setenv(user_cache.VARIABLE, "off")
        assert model.kinematic_lanes(3, ()).native is None
        assert model.speed_lanes(3, ()).native is None
        monkeypatch.setenv(user_cache.VARIABLE, "load")
        assert model.kinematic_lanes(3, ()) is compiled
    finally:
        _fresh_lanes()


def test_a_quantitys_lanes_made_under_one_mode_are_not_given_under_another(loaded,
                                                                            monkeypatch):
    """The lanes a quantity's search samples a function on (``extremes.lanes_of``) are made
    once per ``OPTDESIGN_COMPILE`` as well: compiled under ``load``, the NumPy lanes alone
    under ``off``, the compiled ones again under ``load``."""
    from optdesign.quantities import extremes

    fn = function("fourbar_converter", "speeds")
    compiled = extremes.lanes_of(fn)
    if compiled is None or compiled.native is None:
        pytest.skip("no compiled lanes of this function on this machine")
    monkeypatch.setenv(user_cache.VARIABLE, "off")
    assert extremes.lanes_of(fn).native is None
    monkeypatch.setenv(user_cache.VARIABLE, "load")
    assert extremes.lanes_of(fn) is compiled

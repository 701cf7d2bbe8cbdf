"""A mechanism's lanes made from their record (optdesign.numerics.lanes_index): no function
built, the very code and compiled loop of those made from the function (the same values to
the bit); a record named by what the lanes are made from, passed over where anything it
names is gone, and never written for lanes that lack a loop they may run."""
import shutil

import numpy as np
import pytest

from optdesign.mechanisms import get_mechanism
from optdesign.numerics import c_library, lanes_index, native_lanes, user_cache
from optdesign.numerics.angle_lanes import AngleLanes, lane_functions
from optdesign.numerics.lanes import Lanes
from tests.conftest import kept_files
from tests.test_angle_lanes import inputs

KINDS = ("kinematics", "speeds")
COMPILER = c_library.COMPILER
COUNT = 3


def made(name: str, kind: str, count: int = COUNT):
    """The mechanism's lanes of ``kind`` as a solve asks for them (its record read or
    written), the mechanism's lru caches emptied first (a new process)."""
    model = get_mechanism(name)
    model.lanes_made.cache_clear()
    return (model.kinematic_lanes if kind == "kinematics" else model.speed_lanes)(count, ())


def same(a, b) -> bool:
    return all(np.array_equal(x, y, equal_nan=True) for x, y in zip(a, b))


@pytest.fixture
def numpy_only(own_cache, monkeypatch):
    """The user's own cache folder, on a machine where no compiled loop may run (the lanes
    whole without one)."""
    monkeypatch.setattr(native_lanes, "eligible", lambda functions: False)
    return own_cache


@pytest.mark.parametrize("name", ["fourbar_converter", "slotted_lever"])
@pytest.mark.parametrize("kind", KINDS)
def test_lanes_made_from_their_record_are_those_made_from_the_function(numpy_only, name, kind):
    first = made(name, kind)
    assert first.fn is not None and len(kept_files(numpy_only, "kept-lanes-")) == 1
    again = made(name, kind)
    assert again.fn is None                          # no function built for them
    assert type(again) is type(first) and again.instructions == first.instructions
    if isinstance(first, AngleLanes):
        assert again.places == first.places and len(again.stages) == len(first.stages)
    args = inputs(name, 257)
    assert same(again(*args), first(*args))
    assert len(kept_files(numpy_only, "kept-lanes-")) == 1


def test_a_record_is_named_by_what_the_lanes_are_made_from(numpy_only, monkeypatch):
    four = get_mechanism("fourbar_converter")
    key = lanes_index.key_of(four, "kinematics", 6, ())
    assert key == lanes_index.key_of(get_mechanism("fourbar_converter"), "kinematics", 6, ())
    others = [lanes_index.key_of(four, "speeds", 6, ()),
              lanes_index.key_of(four, "kinematics", 7, ()),
              lanes_index.key_of(four, "kinematics", 6, (("branch", "right"),)),
              lanes_index.key_of(get_mechanism("slotted_lever"), "kinematics", 6, ())]
    assert key not in others and len(set(others)) == len(others)
    monkeypatch.setenv(user_cache.VARIABLE, "load")         # no build started: the same lanes
    assert lanes_index.key_of(four, "kinematics", 6, ()) == key
    monkeypatch.setenv(user_cache.VARIABLE, "off")
    assert lanes_index.key_of(four, "kinematics", 6, ()) is None


def test_a_mechanism_whose_model_is_not_the_packages_own_is_never_recorded(numpy_only,
                                                                           monkeypatch):
    four = get_mechanism("fourbar_converter")
    own = four.chain_expressions
    monkeypatch.setattr(four, "chain_expressions", lambda *a: own(*a))
    assert lanes_index.key_of(four, "kinematics", COUNT, ()) is None
    made("fourbar_converter", "kinematics")
    assert kept_files(numpy_only, "kept-lanes-") == []


@pytest.mark.parametrize("kind", KINDS)
def test_a_record_whose_code_is_gone_or_changed_is_passed_over(numpy_only, kind):
    first = made("fourbar_converter", kind)
    [record] = kept_files(numpy_only, "kept-lanes-")
    for code in kept_files(numpy_only, "lanes-"):
        code.unlink()
    again = made("fourbar_converter", kind)
    assert again.fn is not None                      # made from the function
    args = inputs("fourbar_converter", 65)
    assert same(again(*args), first(*args))
    data = bytearray(record.read_bytes())            # a bit flipped: not read
    data[len(data) // 3] ^= 1
    record.write_bytes(bytes(data))
    assert lanes_index.read(lanes_index.key_of(get_mechanism("fourbar_converter"), kind,
                                                COUNT, ())) is None
    assert made("fourbar_converter", kind).fn is not None


def test_lanes_without_the_loop_they_may_run_are_not_recorded(own_cache):
    """No compiled loop in the folder yet (its build not done) where one may run: a record
    would keep later processes on the NumPy lanes once it is there."""
    lanes = Lanes(get_mechanism("fourbar_converter").speeds(COUNT, ()))
    if not native_lanes.eligible(set(lanes._kernel.__code__.co_names)):
        pytest.skip("no compiled loop may run this function on this machine")
    assert lanes.native is None and lanes.record() is None
    made("fourbar_converter", "speeds")
    assert kept_files(own_cache, "kept-lanes-") == []


@pytest.mark.skipif(shutil.which("gcc") is None, reason="no gcc on PATH")
def test_a_record_names_the_compiled_loops_and_is_passed_over_without_them(own_cache,
                                                                          monkeypatch):
    monkeypatch.setattr(c_library, "COMPILER", COMPILER)     # warm-up's builds, waited for
    monkeypatch.setenv(user_cache.VARIABLE, "load")          # and no other started
    model = get_mechanism("fourbar_converter")
    functions = lane_functions(model.kinematics(COUNT, ()))
    loops = [native_lanes.recipe(fn, text) for fn, text in functions]
    for rec, path, _, note in c_library.warm_up(loops, own_cache):
        assert path is not None, note
    first = made("fourbar_converter", "kinematics")
    if first.native is None:
        pytest.skip("no compiled loop may run these stages on this machine")
    again = made("fourbar_converter", "kinematics")
    assert again.fn is None and again.native is not None
    assert [s.native.digest for s in again.stages] == [s.native.digest for s in first.stages]
    args = inputs("fourbar_converter", 129)
    assert same(again(*args), first(*args))
    for library in kept_files(own_cache, "native-lanes-"):
        library.unlink()
    assert made("fourbar_converter", "kinematics").fn is not None

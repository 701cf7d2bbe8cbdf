"""The kinematics' lanes with the rocker angles taken outside them (optdesign.numerics.angle_lanes):
the very values of the whole function's NumPy lanes, to the bit, on the NumPy statements and on
the compiled loop of the angles' legs, which runs where NumPy's arctan2 is not the C library's
(a machine with AVX-512)."""
import shutil

import numpy as np
import pytest

from optdesign.evaluation.design import Design
from optdesign.mechanisms import get_mechanism
from optdesign.numerics import c_library, native_lanes, user_cache
from optdesign.numerics.angle_lanes import AngleLanes, angle_lanes, legs_of
from optdesign.numerics.lanes import Lanes
from optdesign.problem.loader import problem_from_dict
from tests.conftest import ROOT, file_data

MECHANISMS = ("fourbar_converter", "slotted_lever")


#: a shipped problem of each mechanism whose design the inputs lie around
FILES = {"fourbar_converter": "sharkov2022.yaml", "slotted_lever": "vergov.yaml"}


def inputs(name: str, lanes: int, seed: int = 5):
    """Crank angles and lengths around the shipped design of the mechanism, ``lanes`` of each."""
    problem = problem_from_dict(file_data(ROOT / "problems" / FILES[name]))
    design = Design.from_problem(problem)
    values = np.array([design.values[k] for k in problem.model.lengths])
    rng = np.random.default_rng(seed)
    phi = rng.uniform(0.0, 2 * np.pi, (1, lanes))
    return phi, values[:, None] * rng.uniform(0.8, 1.2, (values.size, lanes))


def _numpy(lanes, *args):
    """``lanes`` on its NumPy statements alone."""
    inner = lanes.legs if isinstance(lanes, AngleLanes) else lanes
    native, inner.native = inner.native, None
    try:
        return lanes(*args)
    finally:
        inner.native = native


def _same(a, b) -> bool:
    return all(np.array_equal(x, y, equal_nan=True) for x, y in zip(a, b, strict=True))


@pytest.mark.parametrize("name", MECHANISMS)
@pytest.mark.parametrize("count", [3, 6])
def test_the_angles_outside_the_lanes_are_the_whole_functions_values(name, count):
    fn = get_mechanism(name).kinematics(count, ())
    split = angle_lanes(fn)
    assert isinstance(split, AngleLanes)
    if name == "slotted_lever":             # (the four-bar's pins turn with an atan2 inside)
        assert "arctan2" not in split.legs._kernel.__code__.co_names
    for lanes in (1, 4096 + 37, 3 * 4096):       # one lane, a pass and a tail, three passes
        args = inputs(name, lanes)
        assert _same(_numpy(split, *args), Lanes(fn)(*args))


def test_a_function_without_angles_first_keeps_its_lanes():
    """The speeds (dθ/dφ first) and a function of no atan2 at all: plain lanes."""
    speeds = get_mechanism("fourbar_converter").speeds(6, ())
    assert legs_of(speeds) is None and isinstance(angle_lanes(speeds), Lanes)
    assert isinstance(angle_lanes(get_mechanism("pulse_reducer").kinematics(3, ())), Lanes)


@pytest.mark.skipif(shutil.which("gcc") is None, reason="no gcc on PATH")
def test_the_compiled_legs_give_the_same_values_to_the_bit(tmp_path, monkeypatch):
    """The slotted lever's legs are free of atan2, so their compiled loop is used wherever
    sine and cosine agree with the C library's; the angles and the rest are the NumPy lanes'
    to the bit."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.setenv(user_cache.VARIABLE, "load")
    where = user_cache.folder()
    fn = get_mechanism("slotted_lever").kinematics(5, ())
    legs = legs_of(fn)
    for rec, path, _, note in c_library.warm_up([native_lanes.recipe(legs, legs.serialize())],
                                                where):
        assert path is not None, note
    split = angle_lanes(fn)
    if not native_lanes.eligible(set(split.legs._kernel.__code__.co_names)):
        pytest.skip("NumPy's sine or cosine is not the C library's on this machine")
    assert split.native is not None
    args = inputs("slotted_lever", 2048 + 5)
    assert _same(split(*args), Lanes(fn)(*args))
    assert _same(split(*args), _numpy(split, *args))


def test_a_design_samples_its_grid_through_the_split_lanes():
    """The exact evaluator's grid (``Design.sample``) reads the kinematics' angle lanes."""
    problem = problem_from_dict(file_data(ROOT / "problems" / FILES["fourbar_converter"]))
    design = Design.from_problem(problem)
    assert isinstance(design.model.kinematic_lanes(design.count, design.option_key),
                      AngleLanes)
    phi = np.linspace(0.0, 2 * np.pi, 1024, endpoint=False)
    out = design.sample(phi)
    assert set(out) == {"theta", "dtheta", "ddtheta", "cos_mu"}
    assert np.all(np.abs(out["theta"]) <= np.pi)

"""The kinematics' lanes cut at every atan2 (optdesign.numerics.angle_lanes): the very values of
the whole function's NumPy lanes, to the bit, on the NumPy statements and on the compiled loops
of the stages, which run where NumPy's arctan2 is not the C library's (a machine with AVX-512)."""
import shutil

import casadi as ca
import numpy as np
import pytest

from optdesign.evaluation.design import Design
from optdesign.mechanisms import get_mechanism
from optdesign.numerics import c_library, native_lanes, user_cache
from optdesign.numerics.angle_lanes import (AngleLanes, angle_lanes, kept_split, lane_functions,
                                            split)
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
    native, lanes.native = lanes.native, None
    try:
        return lanes(*args)
    finally:
        lanes.native = native


def _same(a, b) -> bool:
    return all(np.array_equal(x, y, equal_nan=True) for x, y in zip(a, b, strict=True))


def _kernels_call(lanes: AngleLanes) -> set[str]:
    return {name for stage in lanes.stages for name in stage._kernel.__code__.co_names}


@pytest.mark.parametrize("name", MECHANISMS)
@pytest.mark.parametrize("count", [2, 3, 6])
def test_the_stages_give_the_whole_functions_values(name, count):
    fn = get_mechanism(name).kinematics(count, ())
    cut = angle_lanes(fn)
    assert isinstance(cut, AngleLanes)
    assert "arctan2" not in _kernels_call(cut)          # every atan2 is outside the lanes
    # the four-bar's rockers turn with the coupler's angle: a stage for it, one for the rest
    assert len(cut.stages) == (2 if name == "fourbar_converter" else 1)
    for lanes in (1, 4096 + 37, 3 * 4096):       # one lane, a pass and a tail, three passes
        args = inputs(name, lanes)
        assert _same(_numpy(cut, *args), Lanes(fn)(*args))


@pytest.mark.parametrize("options", [(("pin_layout", "text"),), (("branch", "right"),)])
def test_the_four_bars_other_options_cut_to_the_same_values(options):
    fn = get_mechanism("fourbar_converter").kinematics(5, options)
    args = inputs("fourbar_converter", 999, seed=11)
    assert _same(_numpy(angle_lanes(fn), *args), Lanes(fn)(*args))


def test_a_chain_of_angles_takes_a_stage_each():
    """An angle whose legs take an angle that takes another: three stages, an output of the
    last stage's angle filled by NumPy, one of an earlier angle passed through."""
    x = ca.SX.sym("x", 3)
    a = ca.atan2(x[0], x[1])
    b = ca.atan2(ca.sin(a) * x[2], x[1] + a)
    c = ca.atan2(b, x[0] - b * b)
    fn = ca.Function("chain", [x], [ca.vertcat(c, a, ca.cos(b)), ca.vertcat(b * x[2])])
    cut = split(fn)
    assert len(cut.stages) == 3 and [p[:2] for p in cut.places] == [(0, 0)]
    args = np.random.default_rng(3).uniform(-2.0, 2.0, (3, 513))
    assert _same(AngleLanes(fn, cut)(args), Lanes(fn)(args))


def test_a_function_without_atan2_keeps_its_lanes():
    """The screening's speeds (written without the coupler's angle) and the pulse reducer's
    kinematics: plain lanes."""
    speeds = get_mechanism("fourbar_converter").speeds(6, ())
    assert split(speeds) is None and isinstance(angle_lanes(speeds), Lanes)
    assert isinstance(angle_lanes(get_mechanism("pulse_reducer").kinematics(3, ())), Lanes)


def test_the_cut_is_kept_and_read_back(tmp_path, monkeypatch):
    """A second process reads the stages from the cache, the very functions (as CasADi writes
    them); a kept file changed since it was written is not read but made again."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    fn = get_mechanism("fourbar_converter").kinematics(4, ())
    made = kept_split(fn)
    files = list(user_cache.folder().glob("angle-stages-*.json"))
    assert len(files) == 1
    again = kept_split(fn)
    assert again.texts == made.texts and again.places == made.places
    files[0].write_bytes(files[0].read_bytes().replace(b"stage", b"stagE", 1))
    assert kept_split(fn).texts == made.texts
    assert [t for _, t in lane_functions(fn)] == list(made.texts)


def test_a_function_without_atan2_is_kept_as_such(tmp_path, monkeypatch):
    """The pulse reducer's kinematics hold no atan2: kept so, a second process reads that
    and makes no split (nor writes the file again)."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    fn = get_mechanism("pulse_reducer").kinematics(3, ())
    assert kept_split(fn) is None
    [kept] = user_cache.folder().glob("angle-stages-*.json")
    written = kept.stat().st_mtime_ns
    monkeypatch.setattr("optdesign.numerics.angle_lanes.split",
                        lambda fn: pytest.fail("split again"))
    assert kept_split(fn) is None and kept.stat().st_mtime_ns == written


def test_without_a_cache_the_whole_function_runs_on_the_lanes(monkeypatch):
    monkeypatch.setenv(user_cache.VARIABLE, "off")
    fn = get_mechanism("fourbar_converter").kinematics(3, ())
    assert isinstance(angle_lanes(fn), Lanes)
    assert lane_functions(fn)[0][0] is fn


@pytest.mark.skipif(shutil.which("gcc") is None, reason="no gcc on PATH")
@pytest.mark.parametrize("name", MECHANISMS)
def test_the_compiled_stages_give_the_same_values_to_the_bit(tmp_path, monkeypatch, name):
    """The stages are free of atan2, so their compiled loops are used wherever sine and
    cosine agree with the C library's; every output is the NumPy lanes' to the bit."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.setenv(user_cache.VARIABLE, "load")
    where = user_cache.folder()
    fn = get_mechanism(name).kinematics(5, ())
    recipes = [native_lanes.recipe(f, text) for f, text in lane_functions(fn)]
    for rec, path, _, note in c_library.warm_up(recipes, where):
        assert path is not None, note
    cut = angle_lanes(fn)
    if not native_lanes.eligible(_kernels_call(cut)):
        pytest.skip("NumPy's sine or cosine is not the C library's on this machine")
    assert cut.native is not None and all(loop is not None for loop in cut.native)
    args = inputs(name, 2048 + 5)
    assert _same(cut(*args), Lanes(fn)(*args))
    assert _same(cut(*args), _numpy(cut, *args))
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

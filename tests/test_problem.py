"""Every error a user can meet in a problem file: exit code 2, one line naming file and key."""
import subprocess
import sys

import pytest
import yaml

from optdesign.cli import main
from optdesign.errors import ProblemError
from optdesign.problem.loader import SOLVER_INTEGERS, load_problem
from tests.conftest import ROOT, base_problem


def test_the_paper_problem_loads():
    p = load_problem(ROOT / "problems" / "sharkov2022.yaml")
    assert p.mechanism == "fourbar_converter"
    assert p.counts() == [6]
    assert p.free_lengths() == []
    assert p.eccentricities == (1.0, 0.5, 0.25)


def design(**changes):
    d = base_problem()["design"]
    d.update(changes)
    return base_problem(design=d)


BAD = [
    (design(l3="long"), r"p\.yaml: design\.l3 must be a number \(got 'long'\)"),
    (design(l3=-5), r"p\.yaml: design\.l3 must be positive \(got -5\)"),
    (design(l3=0), r"p\.yaml: design\.l3 must be positive \(got 0\)"),
    (design(l3=float("nan")), r"p\.yaml: design\.l3 must be finite"),
    (design(l3=float("inf")), r"p\.yaml: design\.l3 must be finite"),
    (design(l3=True), r"p\.yaml: design\.l3 must be a number"),
    (design(l2={"lower": 300, "upper": 100}),
     r"p\.yaml: design\.l2\.upper must not be below lower \(got 100 < 300\)"),
    (design(l2={"lower": 100}), r"p\.yaml: design\.l2\.upper is required"),
    (design(l2={"lower": 100, "upper": 300, "initial": 400}),
     r"p\.yaml: design\.l2\.initial must lie within \[100, 300\]"),
    (design(l2={"lower": 100, "upper": 300, "step": 1}),
     r"p\.yaml: design\.l2\.step is not a known key"),
    (design(phases=1), r"p\.yaml: design\.phases must be at least 2 \(got 1\)"),
    (design(phases=4.5), r"p\.yaml: design\.phases must be a whole number \(got 4\.5\)"),
    (design(phases={"lower": 6, "upper": 3}), r"design\.phases\.upper must not be below lower"),
    (design(phases={"choices": []}), r"design\.phases\.choices must be a non-empty list"),
    (design(phases={"choices": [4, 1]}), r"design\.phases\.choices must be at least 2"),
    (design(l9=3), r"p\.yaml: design\.l9 is not a known key; known: l0, l1, l2"),
    (design(l1=300), r"p\.yaml: design\.l1 must be shorter than l0"),
    (base_problem(mechanism="cam"),
     r"p\.yaml: mechanism must be one of fourbar_converter, pulse_reducer, slotted_lever "
     r"\(got 'cam'\)$"),
    (base_problem(mechanism="fourbar_convertor"),
     r"p\.yaml: mechanism must be one of .* \(got 'fourbar_convertor'; did you mean "
     r"fourbar_converter\?\)$"),
    (base_problem(stroke="sideways"),
     r"p\.yaml: stroke must be one of forward, reverse \(got 'sideways'\)$"),
    (base_problem(stroke="Forward"),
     r"p\.yaml: stroke must be one of forward, reverse \(got 'Forward'; did you mean "
     r"forward\?\)$"),
    (base_problem(options={"branch": "lefft"}),
     r"options\.branch must be one of left, right \(got 'lefft'; did you mean left\?\)"),
    (base_problem(input_speed=-1), r"p\.yaml: input_speed must be positive"),
    (base_problem(colour="red"), r"p\.yaml: colour is not a known key"),
    (base_problem(objective={"ripple": "rms"}), r"objective\.ripple must be one of midrange, mean"),
    (base_problem(objective={"minimize": "-ratio"}),
     r"objective\.max_ripple is required when minimize is -ratio"),
    (base_problem(objective={"minimize": "cost"}), r"objective\.minimize must be one of"),
    (base_problem(objective={"min_ratio": -0.1}), r"objective\.min_ratio must not be negative"),
    (base_problem(constraints={"min_transmission_angle_deg": 95}),
     r"constraints\.min_transmission_angle_deg must lie in \[0, 90\)"),
    (base_problem(constraints={"grashof": "yes"}), r"constraints\.grashof must be true or false"),
    (base_problem(constraints={"min_pin_radius": -50}),
     r"constraints\.min_pin_radius must not be negative \(got -50\)"),
    (base_problem(regulation={"eccentricity": [1.0, 1.5]}),
     r"regulation\.eccentricity fractions must lie in \(0, 1\]"),
    (base_problem(regulation={"eccentricity": []}), r"regulation\.eccentricity must be a non-empty"),
    (base_problem(options={"branch": "up"}), r"options\.branch must be one of left, right"),
    (base_problem(solver={"samples": 4}), r"solver\.samples must be at least 16"),
    (base_problem(design=[1, 2]), r"p\.yaml: design must be a mapping \(got list\)"),
    # the pin radius belongs to the four-bar converter: a slotted lever has no pins
    ({"mechanism": "slotted_lever", "input_speed": 0.628,
      "design": {"XD": 292, "L": 74, "sections": 1}, "constraints": {"min_pin_radius": 10}},
     r"p\.yaml: constraints\.min_pin_radius is not a known key; .*known: assembly_margin"),
]


@pytest.mark.parametrize("data,message", BAD, ids=[m[:40] for _, m in BAD])
def test_bad_input_is_named(write_problem, data, message):
    path = write_problem(data)
    with pytest.raises(ProblemError, match=message):
        load_problem(path)


@pytest.mark.parametrize("text,message", [
    ("", r"p\.yaml: the file is empty"),
    ("design: [1, 2\n  : :", r"p\.yaml: not valid YAML at line \d+"),
    ("- just\n- a list\n", r"p\.yaml: must hold a mapping of keys \(got list\)"),
    ("mechanism: fourbar_converter\ninput_speed: 1\n", r"p\.yaml: design is required"),
    ("input_speed: 1\n", r"p\.yaml: mechanism is required"),
])
def test_unreadable_files(write_problem, text, message):
    with pytest.raises(ProblemError, match=message):
        load_problem(write_problem(text))


def test_missing_file(tmp_path):
    with pytest.raises(ProblemError, match=r"no such file"):
        load_problem(tmp_path / "absent.yaml")


def test_missing_design_key(write_problem):
    data = base_problem()
    del data["design"]["l3"]
    with pytest.raises(ProblemError, match=r"p\.yaml: design\.l3 is required \(rockers"):
        load_problem(write_problem(data))


def test_cli_bad_input_exits_2_with_one_line(write_problem, capsys):
    path = write_problem(design(l3=-5))
    assert main(["analyze", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "design.l3 must be positive" in err and "Traceback" not in err


def test_cli_usage_error_exits_2():
    proc = subprocess.run([sys.executable, "-m", "optdesign", "analyze"], capture_output=True,
                          text=True)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr and proc.stderr.count("\n") == 1


def test_collapsed_bounds_fix_the_variable(write_problem):
    p = load_problem(write_problem(design(l2={"lower": 225, "upper": 225})))
    assert not p.design["l2"].is_free and p.design["l2"].value == 225


def test_phase_choices_and_ranges(write_problem):
    assert load_problem(write_problem(design(phases={"choices": [8, 4, 4]}))).counts() == [4, 8]
    assert load_problem(write_problem(design(phases={"lower": 3, "upper": 5}))).counts() == [3, 4, 5]


@pytest.mark.parametrize("solver,message", [
    ({"hessian": "bfgs"}, r"solver\.hessian must be one of exact, limited-memory"),
    ({"peak_samples": "yes"}, r"solver\.peak_samples must be true or false"),
    ({"starts": 0}, r"solver\.starts must be at least 1"),
    ({"smoothing": -1}, r"solver\.smoothing must be positive"),
])
def test_bad_solver_settings(write_problem, solver, message):
    with pytest.raises(ProblemError, match=message):
        load_problem(write_problem(base_problem(solver=solver)))


def test_exponent_numbers_without_a_dot_are_numbers(write_problem):
    """PyYAML (YAML 1.1) would read 1e2 as text; a designer means a number."""
    text = (ROOT / "problems" / "sharkov2022.yaml").read_text().replace("input_speed: 97.0",
                                                                        "input_speed: 9.7e1")
    text = text.replace("l0: 225", "l0: 2.25E2").replace("l3: 56", "l3: 56e0")
    p = load_problem(write_problem(text))
    assert p.input_speed == 97.0 and p.design["l0"].value == 225.0 and p.design["l3"].value == 56


# --------------------------------------------------------------------------- limits
@pytest.mark.parametrize("key", sorted(SOLVER_INTEGERS))
def test_solver_integers_have_both_limits(write_problem, key):
    low, high = SOLVER_INTEGERS[key]
    assert getattr(load_problem(write_problem(base_problem(solver={key: high}))).solver,
                   key) == high
    with pytest.raises(ProblemError, match=rf"solver\.{key} must be at most {high} "
                                           rf"\(got {high + 1}\)"):
        load_problem(write_problem(base_problem(solver={key: high + 1})))
    if low > 0:
        with pytest.raises(ProblemError, match=rf"solver\.{key} must be at least {low}"):
            load_problem(write_problem(base_problem(solver={key: low - 1})))


@pytest.mark.parametrize("count, ok", [(64, True), (65, False)])
def test_the_count_has_an_upper_limit(write_problem, count, ok):
    path = write_problem(design(phases={"lower": 2, "upper": count}))
    if ok:
        assert load_problem(path).counts()[-1] == count
    else:
        with pytest.raises(ProblemError, match=r"design\.phases\.upper must be at most 64"):
            load_problem(path)


@pytest.mark.parametrize("value, message", [
    (-1e-200, r"objective\.min_ratio must be 0 or of a magnitude between 1e-100 and 1e\+100"),
    (1e101, r"objective\.min_ratio must be 0 or of a magnitude between"),
    (10 ** 400, r"objective\.min_ratio must be finite and at most 1e\+100 in magnitude"),
])
def test_numbers_outside_the_magnitude_range(write_problem, value, message):
    with pytest.raises(ProblemError, match=message):
        load_problem(write_problem(base_problem(objective={"min_ratio": value})))


def test_zero_and_the_range_ends_are_accepted(write_problem):
    p = load_problem(write_problem(base_problem(input_speed=1e100, objective={"min_ratio": 0})))
    assert p.input_speed == 1e100 and p.constraints.min_ratio == 0
    assert load_problem(write_problem(base_problem(input_speed=1e-100))).input_speed == 1e-100


def test_a_merge_key_overridden_is_not_a_duplicate(write_problem):
    text = (ROOT / "problems" / "sharkov2022.yaml").read_text().replace(
        "objective:\n", "objective:\n  <<: {ripple: mean, min_ratio: 0.1}\n")
    p = load_problem(write_problem(text))
    assert p.objective.ripple == "midrange" and p.constraints.min_ratio == 0.0


def test_a_name_from_a_long_file_stem_is_cut_to_the_limit(tmp_path):
    data = base_problem()
    del data["name"]
    path = tmp_path / ("n" * 150 + ".yaml")
    path.write_text(yaml.safe_dump(data))
    assert load_problem(path).name == "n" * 100


def test_text_values_have_a_length_limit(write_problem):
    with pytest.raises(ProblemError, match=r"stroke must be at most 100 characters \(got 101\)"):
        load_problem(write_problem(base_problem(stroke="f" * 101)))

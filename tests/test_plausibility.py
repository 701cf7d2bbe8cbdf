"""Unit mistakes a problem file may hold: valid values that are warned of, not refused
(optdesign.problem.plausibility): a length in metres, an angle in radians, a speed in rpm."""
import warnings

import pytest

from optdesign.errors import UnitWarning
from optdesign.problem.loader import load_problem, problem_from_dict
from tests.conftest import ROOT, file_data

DISC = ROOT / "problems" / "sharkov2022_disc.yaml"


@pytest.mark.parametrize("changes,phrase", [
    ({"design": {"l0": {"lower": 0.1, "upper": 0.4, "initial": 0.225}, "l1": 0.02,
                 "l2": {"lower": 0.1, "upper": 0.4, "initial": 0.225},
                 "l2_prime": {"lower": 0.03, "upper": 0.3, "initial": 0.1},
                 "l3": {"lower": 0.02, "upper": 0.15, "initial": 0.056}, "phases": 6}},
     "design.l0, design.l1, design.l2, design.l2_prime, design.l3 are under 1 mm (down to "
     "0.02): lengths are in mm (metres?)"),
    ({"design": {"l0": {"lower": 100e3, "upper": 400e3, "initial": 225e3}, "l1": 20e3,
                 "l2": {"lower": 100e3, "upper": 400e3, "initial": 225e3},
                 "l2_prime": {"lower": 30e3, "upper": 300e3, "initial": 100e3},
                 "l3": {"lower": 20e3, "upper": 150e3, "initial": 56e3}, "phases": 6}},
     "design.l0, design.l1, design.l2, design.l2_prime, design.l3 are over 10 m (up to "
     "400000 mm): lengths are in mm"),
    ({"constraints__min_transmission_angle_deg": 0.785},
     "constraints.min_transmission_angle_deg: 0.785 deg is under 2 deg (radians? 0.785 rad "
     "is 45.0 deg)"),
    ({"input_speed": 1432},
     "input_speed: 1432 rad/s is over 1000 rad/s (rpm? 1432 rpm is 150 rad/s)"),
])
def test_each_unit_mistake_is_one_warning_line_and_the_command_goes_on(
        changes, phrase, write_problem, capsys):
    from optdesign.cli import main

    data = file_data(DISC, **changes)
    path = write_problem(data)
    code = main(["analyze", str(path)])
    err = capsys.readouterr().err
    assert code in (0, 1)
    warned = [line for line in err.splitlines() if line.startswith("optdesign: warning: ")]
    assert warned == [f"optdesign: warning: p.yaml: {phrase}"], err
    # the API is the same front door: the loader warns, by the same words
    with pytest.warns(UnitWarning, match=phrase.split(" (")[0].replace(".", r"\.")):
        load_problem(path)


@pytest.mark.parametrize("path", sorted((ROOT / "problems").glob("*.yaml")),
                         ids=lambda p: p.stem)
def test_a_correct_file_is_silent_without_units(path):
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnitWarning)
        load_problem(path)


def test_a_zero_angle_switches_the_rule_off_without_a_word():
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnitWarning)
        problem_from_dict(file_data(DISC, constraints__min_transmission_angle_deg=0))

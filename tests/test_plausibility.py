"""Unit mistakes a problem file may hold: valid values that are warned of, not refused
(optdesign.problem.plausibility): a length in metres, an angle in radians, a speed in rpm."""
import warnings

import pytest

from optdesign.errors import UnitWarning
from optdesign.problem.loader import load_problem, problem_from_dict
from tests.conftest import ROOT, file_data

DISC = ROOT / "problems" / "sharkov2022_disc.yaml"


def _disc_design(scale: float) -> dict:
    """The disc problem's design block with every length times ``scale`` (a unit mistake)."""
    free = {"l0": (100, 400, 225), "l2": (100, 400, 225), "l2_prime": (30, 300, 100),
            "l3": (20, 150, 56)}
    return {"design": {k: {"lower": lo * scale, "upper": hi * scale, "initial": x * scale}
                       for k, (lo, hi, x) in free.items()} | {"l1": 20 * scale, "phases": 6}}


@pytest.mark.parametrize("changes,phrase", [
    (_disc_design(1e-3),
     "design.l0, design.l1, design.l2, design.l2_prime, design.l3 are under 1 mm (down to "
     "0.02): lengths are in mm (metres?)"),
    (_disc_design(1e3),
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


@pytest.mark.parametrize("path", sorted(p for p in (ROOT / "problems").glob("*.yaml")
                                         if not p.stem.startswith("atlas_")),
                         ids=lambda p: p.stem)
def test_a_correct_file_is_silent_without_units(path):
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnitWarning)
        load_problem(path)


def test_a_zero_angle_switches_the_rule_off_without_a_word():
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnitWarning)
        problem_from_dict(file_data(DISC, constraints__min_transmission_angle_deg=0))

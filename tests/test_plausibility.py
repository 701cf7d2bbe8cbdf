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


# ----------------------------------------------------------- fractions given in per cent
def _spreader(**constraints):
    import yaml

    from tests.conftest import ROOT
    data = yaml.safe_load((ROOT / "problems" / "spreader.yaml").read_text())
    data["constraints"].update(constraints)
    return data


def test_a_ratio_bound_in_per_cent_is_warned_at_load_time():
    """Warned, not refused: the solve tells how far out of reach it is
    (tests/solve/test_verdicts.py)."""
    import warnings

    from optdesign.errors import UnitWarning
    from optdesign.problem.loader import problem_from_dict

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        problem_from_dict(_spreader(ratio={"lower": 40}), where="s.yaml")
    text = [str(w.message) for w in caught if issubclass(w.category, UnitWarning)]
    assert len(text) == 1 and text[0].startswith(
        "s.yaml: constraints.ratio.lower: 40 is a ratio (output / input speed), a fraction "
        "(per cent? 40 % is 0.4)")


def test_a_ratio_bound_above_one_is_warned_as_per_cent_or_overdrive():
    import warnings

    from optdesign.errors import UnitWarning
    from optdesign.problem.loader import problem_from_dict

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        problem_from_dict(_spreader(ratio={"lower": 4}), where="s.yaml")
    text = [str(w.message) for w in caught if issubclass(w.category, UnitWarning)]
    assert len(text) == 1 and "constraints.ratio.lower: 4 is a ratio" in text[0] \
        and "per cent? 4 % is 0.04" in text[0] and "overdrive" in text[0]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        problem_from_dict(_spreader(ripple={"upper": 15}), where="s.yaml")
    text = [str(w.message) for w in caught if issubclass(w.category, UnitWarning)]
    assert len(text) == 1 and "constraints.ripple.upper: 15 is a ripple δ, a fraction (per " \
                              "cent? 15 % is 0.15); the midrange δ never exceeds 2" in text[0]


def test_every_first_line_states_the_crank_speed_in_rad_s_and_rpm():
    from tests.conftest import ROOT, run_main

    code, out = run_main(["analyze", ROOT / "problems" / "sharkov2022.yaml"])
    assert out.splitlines()[0].endswith("; ω1 = 97 rad/s (926.3 rpm)")

"""The drive's natural frequencies beside the pulse frequency: a drive whose pulses fall on
√(λ/I2) is warned, one far from it is not; a motor far faster than input_speed is refused."""
import pytest
import yaml

from optdesign.commands.simulate import format_result
from optdesign.dynamics.resonance import natural_frequencies, resonance
from optdesign.dynamics.steady import simulate
from optdesign.errors import ProblemError
from optdesign.problem.loader import problem_from_dict
from tests.conftest import ROOT

#: Sharkov & Kalinin's six-phase converter at 15.5 rad/s, the motor at the crank: six pulses a
#: turn at about 93 rad/s
SLOW = yaml.safe_load((ROOT / "problems" / "sharkov2022_dynamics.yaml").read_text())
SLOW.update(input_speed=15.5)
SLOW["dynamics"].update(motor={"a": 38.2, "b": 2.35}, rtol=1e-6, atol=1e-8)


def _drive(I2):
    data = yaml.safe_load(yaml.safe_dump(SLOW))
    data["dynamics"]["I2"] = I2
    return problem_from_dict(data, where="drive.yaml")


def test_natural_frequencies_are_the_closed_forms():
    nat = natural_frequencies(0.014, 0.05, 2877.0)
    assert nat["output_rad_s"] == pytest.approx((2877 / 0.05) ** 0.5)      # 239.87 rad/s
    assert nat["two_mass_rad_s"] == pytest.approx((2877 * 0.064 / (0.014 * 0.05)) ** 0.5)
    doc = resonance(0.014, 0.33, 2877.0, 6, 15.5)
    assert doc["near"] and doc["closest"]["harmonic"] == 1


@pytest.mark.parametrize("I2, near", [(0.33, True), (0.02, False)])
def test_a_drive_near_resonance_is_warned_and_one_far_from_it_is_not(I2, near):
    r = simulate(_drive(I2))
    doc = r.to_dict()["resonance"]
    # √(2877/0.33) = 93.4 rad/s against 6·ω1 ≈ 93 rad/s; √(2877/0.02) = 379 rad/s, 26 % past
    # the third harmonic (279 rad/s)
    assert doc["near"] is near
    assert doc["pulses_per_turn"] == 6
    assert doc["pulse_rad_s"] == pytest.approx(6 * r.omega_in_mean)
    assert doc["delta_ratio"] == pytest.approx(r.dynamic.delta / r.kinematic.delta)
    text = format_result(r)
    assert "natural √(λ/I2)" in text and "pulses 6·ω1" in text
    assert ("warning: near resonance" in text) is near
    if near:
        assert f"dynamic δ / kinematic δ = {doc['delta_ratio']:.2f}" in text


def test_a_motor_nine_times_too_fast_is_refused_naming_both_speeds():
    data = yaml.safe_load(yaml.safe_dump(SLOW))
    data["dynamics"]["motor"] = {"a": 230.0 * 1.5, "b": 2.35}       # a/b = 146.8 rad/s
    with pytest.raises(ProblemError, match=r"drive\.yaml: dynamics\.motor: the motor's no-load "
                                           r"speed a/b = 345/2\.35 = 146\.8 rad/s against "
                                           r"input_speed 15\.5 rad/s \(9\.5 times it\)"):
        simulate(problem_from_dict(data, where="drive.yaml"))

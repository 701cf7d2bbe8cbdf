"""How a simulation ends: steady (with a period of one or more turns), stalled or not steady,
each with its reason; the paper's instants when events coincide; the four-bar's first turn."""
import json

import numpy as np
import pytest
import yaml

from optdesign.cli import main
from optdesign.dynamics.instants import first_turn_instants, steady_instants
from optdesign.dynamics.integrator import Event
from tests.conftest import ROOT

REDUCER = ROOT / "problems" / "pulse_reducer_dynamics.yaml"
FOURBAR = ROOT / "problems" / "sharkov2022_dynamics.yaml"
#: looser than the files' 1e-8 to save time (1-2 s a run instead of 4-8); the outcomes hold
FAST = {"rtol": 1e-6, "atol": 1e-8, "steady_tol": 1e-5}


def _refuse(constant):
    raise ValueError(f"not JSON: {constant}")


def run(tmp_path, capsys, source, changes, *options):
    """``optdesign simulate --json`` on ``source`` with dynamics ``changes``: exit code,
    strict JSON, stderr lines, the output folder."""
    data = yaml.safe_load(source.read_text())
    data["dynamics"].update(changes)
    path = tmp_path / "case.yaml"
    path.write_text(yaml.safe_dump(data))
    out = tmp_path / "out"
    code = main(["simulate", str(path), "--json", "--out", str(out), *options])
    stdout, stderr = capsys.readouterr()
    return code, json.loads(stdout, parse_constant=_refuse), stderr.splitlines(), out


# ------------------------------------------------------------------ simultaneous events
def test_simultaneous_events_keep_their_recorded_order():
    """At the reducer's dead centre one holder stops (ε of freewheel 0 peaks) at the very
    instant the other's freewheel closes. The steady cycle's instants once sorted (t, Event)
    pairs and failed on that tie ("'<' not supported between instances of 'Event'");
    ties now keep the order the integrator applied them in."""
    half = 0.032
    events = [Event(0.0, 0.0, "engage", 0), Event(0.012, 0.7, "eps_max", 0, 0.01),
              Event(0.020, 1.1, "release", 0), Event(half, np.pi, "engage", 1),
              Event(half, np.pi, "eps_max", 0, 2e-7), Event(0.044, 3.9, "eps_max", 1, 0.01),
              Event(0.052, 4.3, "release", 1)]
    inst = steady_instants(events, 2 * half, ["1", "2"], band=1e-12)
    assert inst == {"freewheel": "1", "t0_in_turn_s": 0.0, "t1_s": 0.012, "t2_s": 0.020,
                    "t3_s": half}
    # an engagement at the very end of the turn wraps to its start
    wrapped = [Event(2 * half, 2 * np.pi, "engage", 0)] + events[1:]
    assert steady_instants(wrapped, 2 * half, ["1", "2"], 1e-12)["t1_s"] == \
        pytest.approx(0.012, abs=1e-15)


def test_the_reducer_hands_over_at_every_dead_centre(tmp_path, capsys):
    """λ = 1e5 undamped once crashed on the tie above, after the whole integration;
    now steady, exit 0, and each freewheel closes and releases in turn, including at the
    turn's end, where the turn-end stop and a closing coincide."""
    code, result, err, _ = run(tmp_path, capsys, REDUCER, FAST | {"stiffness": 1e5})
    assert code == 0 and err == [] and result["status"] == "steady"
    for label in ("1", "2"):
        kinds = [s["kind"] for s in result["switches"]
                 if s["freewheel"] == label and s["kind"] in ("engage", "release")]
        assert kinds and all(a != b for a, b in zip(kinds, kinds[1:]))
    assert abs(result["power_balance"]) < 1e-4


# ------------------------------------------------------------------ stall
def test_a_stalled_output_is_exit_1_with_its_reason(tmp_path, capsys):
    """λ = 100: the reducer's holders swing 0.04 rad a stroke, so the springs reach 4 N·m and
    never lift the 13 N·m load. Once reported as exit 0 "steady" with δ = inf."""
    code, result, err, out = run(tmp_path, capsys, REDUCER, {"stiffness": 100.0})
    assert code == 1 and result["status"] == "stalled" and result["steady"] is False
    assert err == [f"optdesign: case.yaml: {result['reason']}"]
    assert result["reason"].startswith("the output stalls: over a whole turn the freewheels' "
                                       "torque peaks at 4 N·m and never exceeds the load's "
                                       "13 N·m")
    assert result["omega_out_mean"] == 0.0
    for key in ("delta_dynamic", "delta_mean_dynamic"):   # no ripple of a shaft at rest:
        assert result[key] is None and result["non_finite"][key] == "inf"   # null, not inf
    assert result["cycles"] <= 3                    # a whole turn at rest is enough to tell
    written = json.loads((out / "dynamics.json").read_text(), parse_constant=_refuse)
    assert written["status"] == "stalled" and (out / "dynamics_speeds.png").stat().st_size


def test_a_crank_that_cannot_get_round_is_a_stall(tmp_path, capsys):
    """A 2000 N·m load winds the four-bar's freewheels until their reaction holds the 230 N·m
    motor: no turn completes, no cycle to report; dynamics.json still says why."""
    code, result, err, out = run(tmp_path, capsys, FOURBAR, {"load": 2000.0})
    assert code == 1 and result["status"] == "stalled" and result["steady"] is False
    assert result["reason"].startswith("the crank stalls: it did not get round within 50")
    assert err == [f"optdesign: case.yaml: {result['reason']}"]
    assert json.loads((out / "dynamics.json").read_text())["reason"] == result["reason"]


# ------------------------------------------------------------------ periods and bouncing
def test_a_cycle_of_two_turns_is_steady(tmp_path, capsys):
    """The reducer's composite freewheel at λ = 1e4 closes once just before and once just
    after φ = 0 in alternate turns: no one-turn repeat exists (it ran out of 100 turns), the
    two-turn one is found and recorded whole."""
    code, result, err, _ = run(tmp_path, capsys, REDUCER, FAST | {"stiffness": 1e4},
                               "--freewheel", "composite")
    assert code == 0 and err == [] and result["status"] == "steady"
    assert result["period_turns"] == 2 and result["cycles"] <= 20
    assert result["period_s"] == pytest.approx(2 * result["cycle_time_s"], rel=1e-12)
    assert result["omega_in_mean"] == pytest.approx(4 * np.pi / result["period_s"], rel=1e-12)
    assert result["switches"][-1]["phi_deg"] > 360.0        # the record spans both turns
    assert abs(result["power_balance"]) < 1e-3              # 4e-5 at these tolerances


def test_the_bouncing_composite_says_why(tmp_path, capsys):
    """The four-bar's composite freewheel closes with an impact on Φ, whose deceleration is
    ~24 times the load's braking: the output bounces like a ball on a vibrating table and
    repeats after no 1 to 8 turns (100 turns tried, docs/dynamics.md). Said in one line."""
    code, result, err, _ = run(tmp_path, capsys, FOURBAR, {"cycles": 12},
                               "--freewheel", "composite")
    assert code == 1 and result["status"] == "not_steady"
    assert len(err) == 1
    assert "NOT steady after 12 turns: the composite freewheel closes with impacts" in err[0]
    assert "that its spring returns in full, so the output bounces" in result["reason"]
    assert "23.9 times the load's braking T_c/I2" in result["reason"]
    assert "like a ball on a vibrating table" in result["reason"]


def test_a_damped_composite_freewheel_settles(tmp_path, capsys):
    """With damping the composite freewheel is a unilateral Kelvin-Voigt contact: each impact
    loses energy, the bouncing settles into a cycle, and the motor pays for the losses."""
    code, result, err, _ = run(tmp_path, capsys, FOURBAR, FAST | {"damping_ratio": 1.0},
                               "--freewheel", "composite")
    assert code == 0 and result["status"] == "steady"
    assert result["power_in_w"] > result["power_out_w"] > 0


def test_cycles_out_says_what_to_do(tmp_path, capsys):
    code, result, err, _ = run(tmp_path, capsys, FOURBAR, {"cycles": 4})
    assert code == 1 and result["status"] == "not_steady"
    assert err[0].startswith("optdesign: case.yaml: NOT steady after 4 turns: ")
    assert "raise cycles" in result["reason"]


# ------------------------------------------------------------------ the first turn
def test_fourbar_first_turn_starts_at_its_first_carrying_closing(tmp_path, capsys):
    """The four-bar's leading holder is already slowing at φ = 0, so the freewheel closed by
    the start state lets go at once (ε never above 0); the first turn's figures were then
    t1 = t2 = 0 and ε max = 0. They now start at the next closing that carries (t0)."""
    code, result, _, _ = run(tmp_path, capsys, FOURBAR, {"cycles": 1})
    first = result["first_turn"]
    assert 0 < first["t0_s"] < first["t1_s"] < first["t2_s"] < first["t3_s"]
    assert first["eps_max"] > 1e-3
    assert first["freewheel"] == "6" and first["t3_freewheel"] != "6"


def test_first_turn_skips_a_closing_that_never_carries():
    """Unit: the start's closing (ε peaks at 0 and releases at once) is passed over."""
    events = [Event(0.0, 0.0, "eps_max", 0, 0.0), Event(1e-8, 1e-6, "release", 0),
              Event(0.001, 0.1, "engage", 1), Event(0.009, 0.9, "eps_max", 1, 0.02),
              Event(0.014, 1.4, "release", 1), Event(0.026, 2.6, "engage", 2)]
    first = first_turn_instants(events, ["1", "2", "3"], lead=0, band=1e-12)
    assert first == {"freewheel": "2", "t0_s": 0.001, "t1_s": 0.009, "t2_s": 0.014,
                     "t3_s": 0.026, "t3_freewheel": "3", "eps_max": 0.02}


def test_the_bouncing_is_mechanics_not_numerics():
    """Turn by turn the composite four-bar's energy balances, W_motor - W_load = ΔKE +
    Δ(½λε²), to 1e-6 of the turn's work (observed 1e-7 and below) through every impact and
    flight: the motion that never repeats is the model's, not an event lost or doubled."""
    from dataclasses import replace

    from optdesign.evaluation.design import Design
    from optdesign.dynamics.integrator import Integrator
    from optdesign.dynamics.model import DriveModel
    from optdesign.dynamics.steady import _initial_state, _rebase
    from optdesign.problem.loader import load_problem

    problem = load_problem(FOURBAR)
    section = replace(problem.sections["dynamics"], freewheel="composite")
    model = DriveModel(Design.from_problem(problem), problem.stroke, problem.input_speed,
                       section)
    integ = Integrator(model, "Radau", section.rtol, section.atol)

    def energy(y, mode):
        eps = model.forces(y, mode)[3]
        return model.kinetic_energy(y) + 0.5 * float(
            np.sum(np.where(mode.engaged, model.stiffness * eps ** 2, 0.0)))

    y, mode = _initial_state(model)
    impacts = 0
    for _ in range(6):
        before = energy(y, mode)
        y_end, mode, events, _ = integ.run_turn(y, mode)
        impacts += sum(e.kind == "engage" and e.speed > 1.0 for e in events)
        work = y_end[4] - y_end[5]
        assert abs(work - (energy(y_end, mode) - before)) <= 1e-6 * y_end[4]
        y, mode = _rebase(model, y_end, mode)
    assert impacts >= 3                  # it does bounce: closings at over 1 rad/s


def test_a_bdf_root_bracketing_failure_is_redone_with_radau(monkeypatch):
    """BDF's dense output only approximates a step's start, so a restart next to a root can
    make scipy's bracketing fail ("f(a) and f(b) must have different signs": the reducer's
    composite freewheel at λ = 1e8, after 17 minutes). That segment is redone with Radau."""
    from dataclasses import replace

    from optdesign.dynamics.integrator import Integrator
    from optdesign.dynamics.steady import simulate
    from optdesign.problem.loader import load_problem

    solve = Integrator._solve
    calls = {"BDF": 0}

    def flaky(self, method, *args):
        if method == "BDF":
            calls["BDF"] += 1
            if calls["BDF"] == 3:
                raise ValueError("f(a) and f(b) must have different signs, but f(0)=1, f(1)=2")
        return solve(self, method, *args)

    monkeypatch.setattr(Integrator, "_solve", flaky)
    problem = load_problem(REDUCER)
    result = simulate(problem, replace(problem.sections["dynamics"], **FAST), method="BDF")
    assert result.status == "steady" and result.counters["fallbacks"] == 1

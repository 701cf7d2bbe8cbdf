"""`optdesign simulate` across its promised range, through the command itself.

Freewheel stiffness 1e2 … 1e8 N·m/rad (per decade) × damping ratio {0, 0.1} × both dynamics
problems, each corner on Radau or BDF in a checkerboard (each method meets every stiffness
and both dampings), plus the composite freewheel and the constant crank. Every run must
end in exit 0 (steady) or exit 1 with ONE line on stderr giving the reason, and print valid
JSON (no NaN, no Infinity) whose ``status`` and ``reason`` say the same; never a traceback
(the command's catch-all would turn one into an "internal error" line, refused here).

Reduced setting, to keep the file near a minute on two busy cores: rtol 1e-6, atol 1e-8 and
two crank turns (``cycles: 2``: one turn to start from, one recorded), and the four figures
replaced by empty ones (tests/dynamics/test_simulate.py draws the real ones). Two turns do
not reach a steady cycle, so most runs here end "NOT steady" (exit 1): what is tested is that
every corner ends in a stated outcome. Undamped, the reducer at λ = 1e7 and 1e8 and the
four-bar at 1e8 ring at √(λ/I2) = 1.4e4 to 4.5e4 rad/s and need 5-20 s a run even so: those
corners, every corner on both methods, and every corner at the problem files' own settings
(100 turns, rtol 1e-8), run in ``benchmarks/dynamics_stiffness.py --sweep``, whose table is
in docs/benchmarks.md.
"""
import json

import pytest
import yaml

from optdesign.cli import main
from optdesign.dynamics.result import STATUSES
from tests.conftest import ROOT

PROBLEMS = {"fourbar": ROOT / "problems" / "sharkov2022_dynamics.yaml",
            "reducer": ROOT / "problems" / "pulse_reducer_dynamics.yaml"}
REDUCED = {"rtol": 1e-6, "atol": 1e-8, "cycles": 2}
STIFFNESS = [1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8]
#: undamped and stiffest, 5-20 s a run even reduced: in the benchmark only
SLOW = {("reducer", 1e7, 0.0), ("reducer", 1e8, 0.0), ("fourbar", 1e8, 0.0)}
METHODS = ("Radau", "BDF")


def _grid():
    for problem in PROBLEMS:
        for k, stiffness in enumerate(STIFFNESS):
            for j, damping in enumerate((0.0, 0.1)):
                # one method a corner, in a checkerboard: at each stiffness one damping runs
                # on Radau and the other on BDF, so each method meets every stiffness and
                # both dampings of both problems (the full cross: the benchmark's --sweep)
                method = METHODS[(k + j) % 2]
                if (problem, stiffness, damping) not in SLOW:
                    yield problem, stiffness, damping, ["--method", method]
    for problem in PROBLEMS:
        for stiffness in (1e2, 1e4, 1e6):
            for damping in (0.0, 0.1):
                yield problem, stiffness, damping, ["--freewheel", "composite"]
                yield problem, stiffness, damping, ["--crank", "constant", "--method", "BDF"]


def _refuse(constant):
    raise ValueError(f"not JSON: {constant}")


@pytest.fixture
def no_figures(monkeypatch):
    """Empty figures instead of the command's four (the angles, the speeds, the loads and
    the natural frequencies: 1.3 s of drawing a run saved)."""
    from matplotlib.figure import Figure

    from optdesign.dynamics import plots, resonance

    def empty(*_):
        return Figure(figsize=(1, 1))

    for module, name in ((plots, "plot_angles"), (plots, "plot_speeds"),
                         (plots, "plot_loads"), (resonance, "plot_frequencies")):
        monkeypatch.setattr(module, name, empty)


def simulate_command(tmp_path, capsys, problem: str, changes: dict, options=()):
    """Run ``optdesign simulate --json`` on a variant of a dynamics problem; return the exit
    code, the parsed JSON (strict: NaN or Infinity fail) and the stderr lines."""
    data = yaml.safe_load(PROBLEMS[problem].read_text())
    data["dynamics"].update(changes)
    path = tmp_path / f"{problem}.yaml"
    path.write_text(yaml.safe_dump(data))
    code = main(["simulate", str(path), "--json", "--out", str(tmp_path / "out"), *options])
    out, err = capsys.readouterr()
    return code, json.loads(out, parse_constant=_refuse), err.splitlines(), path.name


def check_outcome(code, result, err, name):
    """Exit 0 and steady, or exit 1 with one line whose reason the JSON states too."""
    assert result["status"] in STATUSES
    assert code == (0 if result["status"] == "steady" else 1), result["status"]
    if code == 0:
        assert err == [] and result["reason"] is None and result["steady"] is True
    else:
        assert len(err) == 1 and result["reason"], err
        assert err[0] == f"optdesign: {name}: {result['reason']}"
        assert "internal error" not in err[0] and "Traceback" not in err[0]


def check_switches_alternate(result):
    """Within the recorded cycle each freewheel closes and releases in turn: a switch lost
    at a simultaneous event (a dead centre) would show as two closings in a row."""
    for label in {s["freewheel"] for s in result["switches"] if s["freewheel"]}:
        kinds = [s["kind"] for s in result["switches"]
                 if s["freewheel"] == label and s["kind"] in ("engage", "release")]
        assert all(a != b for a, b in zip(kinds, kinds[1:])), (label, kinds)


@pytest.mark.parametrize("problem, stiffness, damping, options", list(_grid()),
                         ids=lambda v: v if isinstance(v, str) else
                         " ".join(v) if isinstance(v, list) else f"{v:g}")
def test_every_corner_ends_in_a_stated_outcome(tmp_path, capsys, no_figures, problem,
                                               stiffness, damping, options):
    code, result, err, name = simulate_command(
        tmp_path, capsys, problem, REDUCED | {"stiffness": stiffness, "damping_ratio": damping},
        options)
    check_outcome(code, result, err, name)
    check_switches_alternate(result)
    if result["status"] == "stalled":
        # an output that never moves has no ripple: null, not Infinity, and the reason says why
        assert result["delta_dynamic"] is None and result["omega_out_mean"] == 0.0
        assert "the output stalls" in result["reason"]
    else:
        assert result["omega_out_mean"] > 0 and result["delta_dynamic"] is not None
        # null only when no freewheel carried in the recorded turn (a composite output may
        # overrun a whole turn, bouncing); a ratchet always closes within a turn
        assert result["eps_max"] is None and "composite" in options or result["eps_max"] > 0
    # the soft reducer stalls (its holders swing 0.04 rad: λ·0.04 = 4 N·m < T_c = 13 N·m);
    # its composite freewheel does not (Φ keeps winding the spring until it lifts the load)
    soft_ratchet = problem == "reducer" and stiffness == 1e2 and "composite" not in options
    assert (result["status"] == "stalled") == soft_ratchet

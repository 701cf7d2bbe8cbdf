"""Extreme cases through the CLI: exit codes and one-line errors (docs/accuracy.md)."""
import json

import pytest

from optdesign.cli import main
from tests.conftest import PAPER, base_problem


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.parametrize("factor", [1e-3, 1e3])
def test_analyze_in_metres_and_micrometres(write_problem, capsys, factor):
    data = base_problem(design={k: (v * factor if k != "phases" else v)
                                for k, v in PAPER.items()})
    code, out, _ = run(capsys, "analyze", str(write_problem(data)), "--json")
    assert code == 0
    fwd = json.loads(out)["strokes"]["forward"]
    assert fwd["delta"] == pytest.approx(0.376413, abs=1e-6)
    assert fwd["ratio"] == pytest.approx(0.344296, abs=1e-6)


def test_analyze_crank_longer_than_rocker_exit_1(write_problem, capsys):
    code, out, err = run(capsys, "analyze", str(write_problem(base_problem(
        design=PAPER | {"l1": 60.0}))), "--json")
    assert code == 1
    failure = json.loads(out)["failure"]
    assert failure["chain"] == 1 and "does not assemble" in failure["message"]


@pytest.mark.parametrize("command", ["analyze", "solve"])
def test_crank_longer_than_frame_exit_2(write_problem, capsys, command):
    code, _, err = run(capsys, command, str(write_problem(base_problem(
        design=PAPER | {"l1": 300.0}))))
    assert code == 2
    assert err.strip().count("\n") == 0
    assert "p.yaml: design.l1 must be shorter than l0" in err


def test_analyze_tiny_eccentricity_and_grashof_limit(write_problem, capsys):
    data = base_problem(design=PAPER | {"l2": 261.0},
                        regulation={"eccentricity": [1.0, 1e-6]})
    code, out, err = run(capsys, "analyze", str(write_problem(data)), "--json")
    assert code == 1             # it assembles, and breaks the file's angle of 40° (exit 1)
    assert err.count("\n") == 1 and "the design violates transmission_angle" in err
    res = json.loads(out)
    assert res["min_transmission_angle_deg"] == pytest.approx(0.0, abs=1e-3)
    assert "NaN" not in out and "Infinity" not in out


def test_solve_toggle_design_is_infeasible_not_a_traceback(write_problem, capsys, tmp_path):
    """The Grashof-limit design with every length fixed: μ = 0 < 40°: exit 1, named."""
    data = base_problem(design=PAPER | {"l2": 261.0})
    code, out, err = run(capsys, "solve", str(write_problem(data)), "--json", "--no-plots",
                         "--out", str(tmp_path / "out"))
    assert code == 1
    res = json.loads(out)
    assert res["status"] == "infeasible"
    assert "transmission_angle" in res["message"]


def test_bounds_collapsed_to_a_point(write_problem, capsys, tmp_path):
    """lower == upper fixes the variable: the solve returns the design itself."""
    data = base_problem(design=PAPER | {"l2": {"lower": 225, "upper": 225},
                                        "phases": {"lower": 6, "upper": 6}})
    code, out, _ = run(capsys, "solve", str(write_problem(data)), "--json", "--no-plots",
                       "--out", str(tmp_path / "out"))
    assert code == 0
    res = json.loads(out)
    assert res["design"]["l2"] == 225 and res["design"]["phases"] == 6
    assert res["delta"] == pytest.approx(0.376413, abs=1e-6)


def test_inverted_bounds_exit_2(write_problem, capsys):
    data = base_problem(design=PAPER | {"l2": {"lower": 300, "upper": 200}})
    code, _, err = run(capsys, "analyze", str(write_problem(data)))
    assert code == 2
    assert "design.l2.upper must not be below lower (got 200 < 300)" in err


@pytest.mark.parametrize("n, code", [(1, 2), (2, 0), (24, 0)])
def test_phase_count_limits(write_problem, capsys, n, code):
    got, out, err = run(capsys, "analyze", str(write_problem(base_problem(
        design=PAPER | {"phases": n}))), "--json")
    assert got == code
    if code == 2:
        assert "design.phases must be at least 2 (got 1)" in err
    else:
        assert json.loads(out)["strokes"]["forward"]["delta"] >= 0


def test_mirrored_geometry_cli(write_problem, capsys):
    code, out, _ = run(capsys, "analyze", str(write_problem(base_problem(
        options={"branch": "right"}))), "--json")
    assert code == 0
    assert json.loads(out)["strokes"]["forward"]["delta"] == pytest.approx(0.376413, abs=1e-6)


def test_solve_crank_longer_than_rocker_exit_1(write_problem, capsys, tmp_path):
    """A fixed design that does not assemble: solve says so in one result, exit 1."""
    code, out, _ = run(capsys, "solve", str(write_problem(base_problem(
        design=PAPER | {"l1": 60.0}))), "--json", "--no-plots", "--out", str(tmp_path / "o"))
    assert code == 1
    res = json.loads(out)
    assert res["status"] == "infeasible" and "does not assemble" in res["message"]

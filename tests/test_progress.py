"""Long work says where it is: ``bench accuracy`` draws a progress bar over its evaluations on
a terminal (and nothing elsewhere); ``driveline`` prints its figures, margins and verdict, and
``--json`` prints them as JSON."""
import io
import json

import pytest
import yaml

import optdesign.analyses.accuracy as accuracy
from optdesign.analyses.accuracy import Reference, evaluation_count
from optdesign.cli import main
from optdesign.envelope.sampled import StrokeFigures
from optdesign.outputs.atomic import SCHEMA_VERSION
from tests.conftest import ROOT
from tests.test_units import unlisted

DRIVELINE = ROOT / "problems" / "driveline.yaml"


# --------------------------------------------------------------------------- bench accuracy
def test_bench_counts_every_evaluation_and_is_silent_off_a_terminal(tmp_path, capsys,
                                                                     monkeypatch):
    """The real quick benchmark: the bar's total is the number of evaluations it reports;
    stderr (not a terminal here) stays empty; the JSON names its units."""
    calls, real = [], accuracy.accuracy_rows

    def counted(*args, progress=None, **kwargs):
        def tick(n):
            calls.append(n)
            progress(n)
        rows, ref = real(*args, progress=tick, **kwargs)
        calls.append(("rows", len(rows)))
        return rows, ref

    monkeypatch.setattr(accuracy, "accuracy_rows", counted)
    argv = ["bench", "accuracy", str(ROOT / "problems" / "sharkov2022.yaml"), "--quick",
            "--json", "--no-plot", "--out", str(tmp_path)]
    assert main(argv) == 0
    captured = capsys.readouterr()
    assert captured.err == ""
    n_rows = calls.pop()[1]
    assert sum(calls) == evaluation_count(quick=True) == n_rows + 1     # + the reference
    doc = json.loads(captured.out)
    assert doc["schema_version"] == SCHEMA_VERSION and unlisted(doc) == set()
    assert doc["reference"]["omega_midrange"] == doc["reference"]["omega_avg"]
    assert json.loads((tmp_path / "accuracy.json").read_text()) == doc


class Terminal(io.StringIO):
    def isatty(self):
        return True


def test_bench_draws_its_bar_on_a_terminal(tmp_path, monkeypatch, capsys):
    total = evaluation_count(quick=True)
    figures = StrokeFigures.from_extremes(3.0, 1.0, 2.0, 10.0)

    def fake(problem, progress=None, **kwargs):
        for _ in range(total):
            progress(1)
        row = {"method": "sampled", "samples": 16, "smoothing": None, "time_s": 1e-3,
               "delta_error": 0.0, "ratio_error": 0.0, "omega_min_error": 0.0,
               "delta_signed": 0.0}
        return [row], Reference(figures, "fake")

    monkeypatch.setattr(accuracy, "accuracy_rows", fake)
    terminal = Terminal()
    monkeypatch.setattr("sys.stderr", terminal)
    assert main(["bench", "accuracy", "--quick", "--no-plot", "--out", str(tmp_path)]) == 0
    assert "evaluations:   0%" in terminal.getvalue()
    assert f"0/{total}" in terminal.getvalue()
    assert "sampled" in capsys.readouterr().out


def test_evaluation_count_grows_with_the_parts():
    quick, full = evaluation_count(quick=True), evaluation_count()
    assert quick < full
    assert evaluation_count(e=0.5, quick=True) == 1 + 9 + 3          # no surrogate off e = 1
    assert evaluation_count(quick=True, solve=True) == quick + 3       # reference + 2 settings


# --------------------------------------------------------------------------- driveline
def test_driveline_prints_its_figures_margins_and_verdict(tmp_path, capsys):
    assert main(["driveline", str(DRIVELINE), "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "ω_cr = 1191.46 rad/s (11377.7 rpm)" in out
    assert "length 1143 mm between supports" in out
    assert "operating speed  39.8383 rad/s" in out
    # margins: 1191.46 - 39.84 below ω_cr, 0.7 x 1191.46 - 39.84 = 794.19 below the limit
    assert "margin           1151.63 rad/s below ω_cr; 794.187 rad/s below the limit" in out
    assert "check            holds" in out


def test_driveline_json(tmp_path, capsys):
    assert main(["driveline", str(DRIVELINE), "--out", str(tmp_path), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["verdict"] == "holds" and d["speed_constraint_holds"] is True
    assert d["speed_margin_rad_s"] == pytest.approx(
        0.7 * d["critical_speed_rad_s"] - d["operating_speed_rad_s"], rel=1e-12)
    assert d["critical_margin_rad_s"] == pytest.approx(
        d["critical_speed_rad_s"] - d["operating_speed_rad_s"], rel=1e-12)
    assert d["figure"] == str(tmp_path / "driveline.png")
    assert (tmp_path / "driveline.png").exists()
    assert d["schema_version"] == SCHEMA_VERSION and unlisted(d) == set()


def _variant(tmp_path, change) -> str:
    data = yaml.safe_load(DRIVELINE.read_text())
    change(data)
    path = tmp_path / "variant.yaml"
    path.write_text(yaml.safe_dump(data))
    return str(path)


def test_driveline_violated_unchecked_and_without_an_output_speed(tmp_path, capsys):
    fast = _variant(tmp_path, lambda d: d["driveline"].update(speed_factor=25.0))
    assert main(["driveline", fast, "--out", str(tmp_path / "a"), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["verdict"] == "violated" and d["speed_margin_rad_s"] < 0

    free = _variant(tmp_path, lambda d: d["constraints"].pop("max_speed_fraction_of_critical"))
    assert main(["driveline", free, "--out", str(tmp_path / "b")]) == 0
    out = capsys.readouterr().out
    assert "check            not checked" in out and "below the limit" not in out

    broken = _variant(tmp_path, lambda d: d["design"].update(l3=20))   # does not assemble
    assert main(["driveline", broken, "--out", str(tmp_path / "c"), "--json"]) == 1
    d = json.loads(capsys.readouterr().out)
    assert d["verdict"] == "no_output_speed" and d["assembles"] is False
    assert d["operating_speed_rad_s"] is None and d["critical_speed_rad_s"] > 0
    assert "does not assemble" in d["failure"]["message"]
    assert (tmp_path / "c" / "driveline.png").exists()


def test_simulate_reports_each_turn_to_its_progress_callback():
    from optdesign.dynamics.steady import simulate
    from optdesign.problem.loader import load_problem
    from tests.conftest import ROOT

    turns = []
    result = simulate(load_problem(ROOT / "problems" / "sharkov2022_dynamics.yaml"),
                      progress=lambda: turns.append(1))
    assert len(turns) == result.cycles >= 1


# --------------------------------------------------------------------------- solve
class _Bar:
    def __init__(self):
        self.n = 0

    def update(self):
        self.n += 1


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_a_long_solve_says_each_count_off_a_terminal_and_a_short_one_nothing():
    """Off a terminal the bar is silent: a solve that has run long enough writes a line per
    count it finishes (a wide range of counts took minutes with nothing in its log); a short
    solve, and any solve on a terminal (the bar), writes none."""
    from optdesign.outputs.progress_lines import CountLines

    log, bar = io.StringIO(), _Bar()
    tick = CountLines(bar, 3, stream=log, after_s=0.0)
    tick(), tick()
    lines = log.getvalue().splitlines()
    assert bar.n == 2 and len(lines) == 2
    assert lines[0].startswith("solve ") and lines[1].endswith(": 2 of 3 phase counts")
    quiet, terminal = io.StringIO(), _Terminal()
    CountLines(_Bar(), 3, stream=quiet)()                   # not yet AFTER_S into the work
    CountLines(_Bar(), 3, stream=terminal, after_s=0.0)()
    assert quiet.getvalue() == "" and terminal.getvalue() == ""

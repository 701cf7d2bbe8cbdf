"""Hostile input through the CLI: every failure is an exit code and one line, found before any
work, within a bounded time and memory (docs/contract.md, "Limits")."""
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest
import yaml

from optdesign.cli import main
from tests.conftest import ROOT, base_problem

PAPER_FILE = ROOT / "problems" / "sharkov2022.yaml"
DRIVELINE_FILE = ROOT / "problems" / "driveline.yaml"
DYNAMICS_FILE = ROOT / "problems" / "sharkov2022_dynamics.yaml"
FREE_FILE = ROOT / "problems" / "sharkov2022_disc.yaml"


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def one_line(err: str) -> str:
    assert err.count("\n") == 1 and "Traceback" not in err, err
    return err.strip()


def strict_json(text: str):
    """json.loads that refuses NaN and Infinity (which Python's reader accepts)."""
    def refuse(constant):
        raise ValueError(f"not JSON: {constant}")
    return json.loads(text, parse_constant=refuse)


def paper_text(old: str, new: str) -> str:
    text = PAPER_FILE.read_text()
    assert old in text
    return text.replace(old, new)


# --------------------------------------------------------------------------- output folders
#: every command that writes, with a problem it accepts and the function its work starts in
WRITERS = [
    ("solve", FREE_FILE, "optdesign.solver.solve"),
    ("curves", PAPER_FILE, "optdesign.analyses.curves.member_curves"),
    ("driveline", DRIVELINE_FILE, "optdesign.analyses.analyze.analyze"),
    ("simulate", DYNAMICS_FILE, "optdesign.dynamics.steady.simulate"),
    ("bench", PAPER_FILE, "optdesign.analyses.accuracy.accuracy_rows"),
    ("pareto", FREE_FILE, "optdesign.fronts.sweep"),
]


def _argv(command, problem, *rest):
    return (["bench", "accuracy", problem] if command == "bench" else [command, problem]) \
        + list(rest)


def _no_work(monkeypatch, target):
    """Make the command's work fail the test if it is reached at all."""
    module, name = target.rsplit(".", 1)

    def called(*a, **k):
        raise AssertionError(f"{target} ran before the output folder was checked")
    monkeypatch.setattr(f"{module}.{name}", called)


@pytest.mark.parametrize("command, problem, target", WRITERS, ids=[w[0] for w in WRITERS])
@pytest.mark.parametrize("case", ["a file", "under a file", "under /proc", "NUL byte"])
def test_bad_out_is_exit_2_before_any_work(tmp_path, capsys, monkeypatch, command, problem,
                                           target, case):
    _no_work(monkeypatch, target)
    (tmp_path / "f").write_text("x")
    out = {"a file": tmp_path / "f", "under a file": tmp_path / "f" / "sub",
           "under /proc": "/proc/optdesign-results", "NUL byte": "a\0b"}[case]
    code, _, err = run(capsys, *_argv(command, problem, "--out", out))
    assert code == 2
    message = one_line(err)
    assert message.startswith("optdesign: --out ")
    assert {"a file": "exists and is not a folder", "under a file": "Not a directory",
            "under /proc": "under /proc", "NUL byte": "not a folder name"}[case] in message
    assert (tmp_path / "f").read_text() == "x"


def test_a_file_of_the_set_that_is_a_folder_is_refused(tmp_path, capsys, monkeypatch):
    _no_work(monkeypatch, "optdesign.analyses.curves.member_curves")
    (tmp_path / "curves.png").mkdir()
    code, _, err = run(capsys, "curves", PAPER_FILE, "--out", tmp_path)
    assert code == 2 and "curves.png there is a folder" in one_line(err)


class read_only:
    """A folder nobody may write into, root included: ``chattr +i`` as root (who ignores
    the mode bits), mode 555 otherwise; skips the test where neither holds."""

    def __init__(self, path):
        self.path, self.root = str(path), os.geteuid() == 0

    def __enter__(self):
        if self.root:
            if not shutil.which("chattr") or subprocess.run(
                    ["chattr", "+i", self.path], capture_output=True).returncode:
                pytest.skip("no chattr +i here to make a folder read-only for root")
        else:
            os.chmod(self.path, 0o555)
        return self

    def __exit__(self, *exc):
        if self.root:
            subprocess.run(["chattr", "-i", self.path], check=True)
        else:
            os.chmod(self.path, 0o755)


@pytest.mark.parametrize("command, problem", [("curves", PAPER_FILE), ("solve", FREE_FILE)])
def test_read_only_working_folder_exit_2_at_once(tmp_path, command, problem):
    """The default results/NAME/ in a read-only folder: exit 2 before the solve."""
    shutil.copy(problem, tmp_path)
    with read_only(tmp_path):
        t0 = time.perf_counter()
        proc = subprocess.run([sys.executable, "-m", "optdesign", command, problem.name],
                              cwd=tmp_path, capture_output=True, text=True, timeout=120,
                              env=os.environ | {"PYTHONPATH": str(ROOT)})
        elapsed = time.perf_counter() - t0
    assert proc.returncode == 2, proc.stderr
    message = one_line(proc.stderr)
    assert f"results/{problem.stem}" in message and "cannot write there" in message
    assert elapsed < 30          # the disc problem's solve alone takes longer
    assert sorted(os.listdir(tmp_path)) == [problem.name]


# --------------------------------------------------------------------------- names
@pytest.mark.parametrize("name, message", [
    ("x" * 300, "name must be at most 100 characters (got 300)"),
    ("a\0b", r"name must hold printable characters only (got 'a\x00b')"),
    ("", "name must not be empty"),
    ("line\nbreak", "name must hold printable characters only"),
])
def test_bad_names_exit_2(write_problem, capsys, name, message):
    code, _, err = run(capsys, "analyze", write_problem(base_problem(name=name)))
    assert code == 2 and message in one_line(err)


@pytest.mark.parametrize("name, folder", [
    ("../../../somewhere", "somewhere"), ("/etc/passwd", "etc_passwd"), ("...", "problem"),
    ("a b/c", "a_b_c"), ("ωμέγα", "ωμέγα"), ("é" * 100, "é" * 60), ("x.", "x")])
def test_names_become_one_folder_name(name, folder):
    from optdesign.outputs.checks import default_out
    assert default_out(name) == Path("results") / folder
    assert default_out(name, "_pareto") == Path("results") / f"{folder}_pareto"


def test_a_name_with_dots_writes_under_results(tmp_path, monkeypatch, capsys):
    (tmp_path / "work").mkdir()
    monkeypatch.chdir(tmp_path / "work")
    path = tmp_path / "p.yaml"
    path.write_text(yaml.safe_dump(base_problem(name="../../../somewhere")))
    code, out, _ = run(capsys, "curves", path, "--samples", "64")
    assert code == 0
    assert sorted(os.listdir(tmp_path)) == ["p.yaml", "work"]
    assert os.listdir("results") == ["somewhere"]
    assert (tmp_path / "work" / "results" / "somewhere" / "curves.png").exists()


# --------------------------------------------------------------------------- the file itself
@pytest.mark.parametrize("text, message", [
    ("a: " + "[" * 5000 + "]" * 5000 + "\n", "nests deeper than 16 levels at line 1"),
    ("a: " + "{b: " * 2000 + "1" + "}" * 2000 + "\n", "nests deeper than 16 levels at line 1"),
    ("".join("  " * i + f"k{i}:\n" for i in range(100)) + "  " * 100 + "x: 1\n",
     "nests deeper than 16 levels at line 16"),
    ("name: a\nname: b\nmechanism: fourbar_converter\n", "has the key 'name' twice in one "
                                                         "mapping at line 2"),
    ("a: &x [*x]\n", "alias *x refers to a node that contains it at line 1"),
    (paper_text("97.0", "9" * 400), "input_speed must be finite and at most 1e+100 in "
                                    "magnitude (got an integer of 1329 bits)"),
    ("name: '" + "x" * 5000 + "'\n", "has a value longer than 1000 characters at line 1"),
    ("when: 2002-13-45\n", "not valid YAML at line 1"),
    ("x" * (1 << 20) + "\n", "is larger than 1024 KiB"),
])
def test_file_limits(write_problem, capsys, text, message):
    code, _, err = run(capsys, "analyze", write_problem(text))
    assert code == 2 and message in one_line(err)


def _bomb(levels=9):
    """``levels`` nested lists of nine aliases each: a few hundred bytes, 9**levels items."""
    names = "abcdefghijklmnop"
    items = ["&a [l, l, l, l, l, l, l, l, l]"]
    items += [f"&{names[i]} [" + ", ".join([f"*{names[i - 1]}"] * 9) + "]"
              for i in range(1, levels)]
    return "[" + ", ".join(items) + "]"


@pytest.mark.parametrize("old, new", [
    ("input_speed: 97.0", "input_speed: {bomb}"),
    ("name: sharkov2022", "name: {bomb}"),
    ("l0: 225", "l0: {{lower: {bomb}, upper: 300}}"),
])
def test_alias_bombs_are_refused_at_once(write_problem, capsys, old, new):
    text = paper_text(old, new.format(bomb=_bomb()))
    assert len(text.encode()) < 1500
    t0 = time.perf_counter()
    code, _, err = run(capsys, "analyze", write_problem(text))
    assert time.perf_counter() - t0 < 5
    assert code == 2 and "holds more than 10000 values (aliases expanded)" in one_line(err)


def test_aliases_within_the_limits_still_work(write_problem, capsys):
    text = paper_text("l0: 225", "l0: &frame 225").replace("l2: 225", "l2: *frame")
    code, out, _ = run(capsys, "analyze", write_problem(text), "--json")
    assert code == 0 and strict_json(out)["design"]["l2"] == 225


@pytest.mark.parametrize("data, message", [
    (b"\xff\xfename: x\n", "is not UTF-8 text (byte 0)"),
    (b"name: \x00\n", "not valid YAML"),
])
def test_bytes_that_are_not_text(tmp_path, capsys, data, message):
    path = tmp_path / "p.yaml"
    path.write_bytes(data)
    code, _, err = run(capsys, "analyze", path)
    assert code == 2 and message in one_line(err)


@pytest.mark.parametrize("kind", ["device", "fifo", "folder"])
def test_problem_file_that_is_not_a_regular_file(tmp_path, capsys, kind):
    path = {"device": "/dev/zero", "fifo": tmp_path / "fifo", "folder": tmp_path}[kind]
    if kind == "fifo":
        os.mkfifo(path)
    t0 = time.perf_counter()
    code, _, err = run(capsys, "analyze", path)
    assert time.perf_counter() - t0 < 5
    assert code == 2
    assert ("is a folder" if kind == "folder" else "is not a regular file") in one_line(err)


def test_error_messages_are_bounded(write_problem, capsys):
    data = base_problem(stroke="s" * 90, objective={"z" * 900: 1})
    code, _, err = run(capsys, "analyze", write_problem(data))
    assert code == 2 and len(one_line(err)) < 300
    code, _, err = run(capsys, "analyze", write_problem(base_problem(input_speed=["x" * 900])))
    assert code == 2 and len(one_line(err)) < 150


# --------------------------------------------------------------------------- numbers and counts
@pytest.mark.parametrize("old, new, message", [
    ("phases: 6", "phases: {lower: 4, upper: 1e9}",
     "design.phases.upper must be at most 64 (got 1e+09)"),
    ("phases: 6", "phases: 1000", "design.phases must be at most 64 (got 1000)"),
    ("phases: 6", "phases: 1e30", "design.phases must be at most 64 (got 1e+30)"),
    ("min_ratio: 0.0", "min_ratio: 0.0\nsolver:\n  samples: 1e30",
     "solver.samples must be at most 2000 (got 1e+30)"),
    ("min_ratio: 0.0", "min_ratio: 0.0\nsolver:\n  max_iter: 2147483648",
     "solver.max_iter must be at most 100000 (got 2147483648)"),
    ("min_ratio: 0.0", "min_ratio: 0.0\nsolver:\n  max_iter: 1e30",
     "solver.max_iter must be at most 100000 (got 1e+30)"),
    ("input_speed: 97.0", "input_speed: 1e-320",
     "input_speed must be between 1e-100 and 1e+100 (got 9.99989e-321)"),
    ("l1: 20", "l1: 1e-320", "design.l1 must be between 1e-100 and 1e+100"),
    ("[1.0, 0.5, 0.25]", "[1.0, 1e-320]", "regulation.eccentricity must be between 1e-100"),
    ("[1.0, 0.5, 0.25]", "[1.0, 1e-12]",
     "regulation.eccentricity fractions must be at least 1e-09 (got 1e-12)"),
    ("[1.0, 0.5, 0.25]", "[" + ", ".join(["0.5"] * 17) + "]",
     "regulation.eccentricity must list at most 16 fractions (got 17)"),
    ("l1: 20", "l1: 1e-15", "design.l1 times the least eccentricity (2.5e-16) must be at "
                            "least 1e-09 of the longest length, l0 = 225"),
])
def test_numbers_and_counts_have_limits(write_problem, capsys, old, new, message):
    t0 = time.perf_counter()
    code, _, err = run(capsys, "analyze", write_problem(paper_text(old, new)))
    assert time.perf_counter() - t0 < 10
    assert code == 2 and message in one_line(err)


@pytest.mark.parametrize("key, value, message", [
    ("wall_mm", 1e-320, "driveline.wall_mm must be between 1e-100"),
    ("wall_mm", 1e-30, "driveline.wall_mm must be at least 1e-06 of outer_diameter_mm"),
    ("density_kg_m3", 1e-320, "driveline.density_kg_m3 must be between 1e-100"),
    ("length_mm", 1e100, "driveline describes a shaft whose figures overflow"),
])
def test_driveline_numbers_that_break_the_model(write_problem, capsys, key, value, message):
    data = yaml.safe_load(DRIVELINE_FILE.read_text())
    data["driveline"][key] = value
    code, _, err = run(capsys, "analyze", write_problem(data))
    assert code == 2 and message in one_line(err)


@pytest.mark.parametrize("file", ["sharkov2022", "vergov", "pulse_reducer"])
def test_ripple_does_not_depend_on_the_input_speed(write_problem, capsys, file):
    """δ and the ratio are ratios of speeds: the same at every accepted ω1 (to 1e-12)."""
    data = yaml.safe_load((ROOT / "problems" / f"{file}.yaml").read_text())
    figures = []
    for speed in (1e-100, 1.0, 1e100):
        code, out, _ = run(capsys, "analyze", write_problem(data | {"input_speed": speed}),
                           "--json")
        assert code == 0
        figures.append(strict_json(out)["strokes"])
    for strokes in figures[::2]:
        for stroke, f in strokes.items():
            for key in ("delta", "ratio", "delta_mean"):
                assert f[key] == pytest.approx(figures[1][stroke][key], rel=1e-12, abs=1e-12)


@pytest.mark.parametrize("argv, message", [
    (["curves", PAPER_FILE, "--samples", "2e9"], "argument --samples: invalid int value"),
    (["curves", PAPER_FILE, "--samples", "2000000000"],
     "--samples must be at most 100000 (got 2000000000)"),
    (["curves", PAPER_FILE, "--eccentricity", "1e-12"], "--eccentricity must be at least 1e-09"),
    (["bench", "accuracy", PAPER_FILE, "--crosscheck", "10000000000"],
     "--crosscheck must be at most 100000000"),
    (["simulate", DYNAMICS_FILE, "--cycles", "1000000000"], "--cycles must be at most 100000"),
    (["pareto", FREE_FILE, "--points", "100000"], "argument --points: must be at most 1000"),
    (["pareto", FREE_FILE, "--workers", "100000"], "argument --workers: must be at most 256"),
    (["atlas", ROOT / "problems" / "atlas_fourbar.yaml", "--workers", "100000"],
     "argument --workers: must be at most 256"),
    (["tolerance", ROOT / "problems" / "sharkov2022_disc_tolerance.yaml", "--samples",
      "10000001"], "--samples must lie in [1, 10000000]"),
    (["animate", PAPER_FILE, "--frames", "721"], "--frames must lie in [8, 720]"),
])
def test_command_line_counts_have_limits(capsys, argv, message):
    try:
        code, _, err = run(capsys, *argv)
    except SystemExit as exc:           # argparse's own checks end the process
        code, err = exc.code, capsys.readouterr().err
    assert code == 2 and message in one_line(err)


def test_a_count_has_one_limit_in_the_file_the_flag_and_the_api(write_problem, capsys):
    """The file's key, the flag and the API's argument take their bound from one table."""
    from optdesign import api
    from optdesign.commands import animate, bench, curves, pareto, tolerance
    from optdesign.dynamics.section import MAX_CYCLES
    from optdesign.errors import ProblemError
    from optdesign.fronts.section import DECLARATION as PARETO
    from optdesign.limits import COUNTS
    from optdesign.problem.loader import SOLVER_INTEGERS
    from optdesign.tolerance.section import DECLARATION as TOLERANCES

    assert (pareto.MAX_POINTS, PARETO.key("points").upper) == (COUNTS["points"],) * 2
    assert (tolerance.MAX_SAMPLES, TOLERANCES.key("samples").upper) == (COUNTS["parts"],) * 2
    assert (MAX_CYCLES, animate.MAX_FRAMES, curves.MAX_SAMPLES, bench.MAX_CROSSCHECK) == \
        (COUNTS["cycles"], COUNTS["frames"], COUNTS["curve_samples"], COUNTS["crosscheck"])
    assert {k: hi for k, (_, hi) in SOLVER_INTEGERS.items() if k != "seed"} == {
        k: COUNTS[{"samples": "nlp_samples"}.get(k, k)] for k in SOLVER_INTEGERS if k != "seed"}
    path = write_problem(paper_text("min_ratio: 0.0", "min_ratio: 0.0\nsolver: {workers: 257}"))
    code, _, err = run(capsys, "analyze", path)
    assert code == 2 and "solver.workers must be at most 256" in one_line(err)
    for kind in ("workers", "points"):
        with pytest.raises(ProblemError, match=f"{kind} must be at most {COUNTS[kind]}"):
            api.pareto(FREE_FILE, **{kind: COUNTS[kind] + 1})


# --------------------------------------------------------------------------- JSON
def test_json_output_has_no_infinity(capsys, monkeypatch):
    """A figure that is not finite is null, and its object says why in non_finite."""
    from optdesign.analyses.analyze import AnalysisResult
    real = AnalysisResult.to_dict

    def with_infinity(self):
        out = real(self)
        out["strokes"]["forward"]["delta_mean"] = float("inf")
        out["regulation"][0]["min_transmission_angle_deg"] = float("nan")
        return out
    monkeypatch.setattr(AnalysisResult, "to_dict", with_infinity)
    code, out, _ = run(capsys, "analyze", PAPER_FILE, "--json")
    assert code == 0
    data = strict_json(out)
    assert data["strokes"]["forward"]["delta_mean"] is None
    assert data["strokes"]["forward"]["non_finite"] == {"delta_mean": "inf"}
    assert data["regulation"][0]["non_finite"] == {"min_transmission_angle_deg": "nan"}


def test_json_files_have_no_infinity(tmp_path):
    import numpy as np

    from optdesign.outputs.atomic import atomic_write_json, json_text
    path = atomic_write_json(tmp_path / "r.json", {"a": [np.inf, 1.0], "b": np.float64("-inf"),
                                                   "c": {"d": np.nan}, "e": np.arange(2)})
    assert strict_json(path.read_text()) == {"a": [None, 1.0], "b": None, "c": {
        "d": None, "non_finite": {"d": "nan"}}, "e": [0, 1], "non_finite": {"b": "-inf"}}
    with pytest.raises(TypeError):
        json_text({"x": object()})


# --------------------------------------------------------------------------- the process
def test_scheduler_that_does_not_answer_is_exit_2_within_seconds(capsys, monkeypatch):
    pytest.importorskip("distributed")
    _no_work(monkeypatch, "optdesign.fronts.sweep")
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        code, _, err = run(capsys, "pareto", FREE_FILE, "--out", tmp,
                           "--scheduler", "tcp://127.0.0.1:9")
        assert time.perf_counter() - t0 < 15
    assert code == 2
    assert "--scheduler 'tcp://127.0.0.1:9': no scheduler answered within 3 s" in one_line(err)
    code, _, err = run(capsys, "pareto", FREE_FILE, "--out", tmp, "--scheduler", "no port")
    assert code == 2 and "malformed address" in one_line(err)


def test_closed_pipe_is_quiet():
    """`optdesign analyze P.yaml | head`: the reader is gone before the output is written."""
    proc = subprocess.Popen([sys.executable, "-m", "optdesign", "analyze", str(PAPER_FILE),
                             "--json"], cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 1
    assert err == ""


@pytest.mark.parametrize("exc, message, code", [
    (ZeroDivisionError("float division by zero"), "optdesign analyze: internal error "
     "(ZeroDivisionError: 'float division by zero'); please report it", 1),
    (MemoryError(), "optdesign analyze: out of memory", 1),
    (OSError(28, "No space left on device", "/x/result.json"),
     "optdesign analyze: No space left on device: '/x/result.json'", 1),
    (RecursionError("maximum recursion depth exceeded"), "internal error (RecursionError", 1),
    (IsADirectoryError(21, "Is a directory", 18), "optdesign analyze: Is a directory: 18", 1),
])
def test_unexpected_errors_are_one_line(capsys, monkeypatch, exc, message, code):
    def fail(problem, values=None):
        raise exc
    monkeypatch.setattr("optdesign.analyses.analyze.analyze", fail)
    got, _, err = run(capsys, "analyze", PAPER_FILE)
    assert got == code and message in one_line(err)
    got, _, err = run(capsys, "--debug", "analyze", PAPER_FILE)
    assert got == code and err.startswith("Traceback")
    assert message in err.strip().splitlines()[-1]

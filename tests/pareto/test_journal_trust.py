"""``--resume`` trusts no record: each is checked for its fields (a damaged one is exit 2 with
its line number) and every feasible one is evaluated exactly again before it enters a front
(an edited δ or ratio, a record moved to another count, is refused with its line)."""
import json
import shutil

import pytest

from optdesign.cli import main
from optdesign.errors import ProblemError
from optdesign.fronts import sweep
from optdesign.problem.loader import load_problem


def _copy(small_front, tmp_path):
    _, out = small_front
    folder = tmp_path / "again"
    folder.mkdir()
    shutil.copy(out / "points.jsonl", folder / "points.jsonl")
    lines = (folder / "points.jsonl").read_text().splitlines()
    return folder, lines


def _edit(folder, lines, number, change):
    rec = json.loads(lines[number - 1])
    change(rec)
    lines = list(lines)
    lines[number - 1] = json.dumps(rec)
    (folder / "points.jsonl").write_text("\n".join(lines) + "\n")


def _feasible_line(lines) -> int:
    return next(i for i, line in enumerate(lines, 1)
                if i > 1 and json.loads(line).get("feasible"))


@pytest.mark.parametrize("change,message", [
    (lambda r: r.update(delta=1e-6, ratio=5.0),
     r"line \d+: the record does not match its design \(delta 1e-06 recorded"),
    (lambda r: r["design"].update(l3=r["design"]["l3"] + 1.0),
     r"line \d+: the record does not match its design"),
    (lambda r: r.update(key=[6, r["key"][1]]),
     r"damaged journal \(line \d+: the record's key names count 6, its count 4\)"),
    (lambda r: r.pop("delta"), r"damaged journal \(line \d+: the record has no delta\)"),
    (lambda r: r.update(feasible="yes"),
     r"damaged journal \(line \d+: the record's feasible is not a bool\)"),
])
def test_an_edited_record_is_refused_with_its_line(small_front, small_path, tmp_path, change,
                                                   message):
    folder, lines = _copy(small_front, tmp_path)
    number = _feasible_line(lines)
    _edit(folder, lines, number, change)
    with pytest.raises(ProblemError, match=message) as info:
        sweep(load_problem(small_path), folder, workers=1, resume=True, progress=False)
    assert f"line {number}" in str(info.value)
    assert (folder / "points.jsonl").read_text().splitlines()[number - 1] != lines[number - 1]


def test_the_command_line_says_it_in_one_line_and_exit_2(small_front, small_path, tmp_path,
                                                         capsys):
    folder, lines = _copy(small_front, tmp_path)
    _edit(folder, lines, _feasible_line(lines), lambda r: r.update(delta=1e-6))
    code = main(["pareto", str(small_path), "--out", str(folder), "--resume",
                 "--workers", "1", "--no-report"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "does not match its design" in err


def test_an_untouched_journal_resumes_to_the_same_front(small_front, small_path, tmp_path):
    result, _ = small_front
    folder, _ = _copy(small_front, tmp_path)
    again = sweep(load_problem(small_path), folder, workers=1, resume=True, progress=False)
    assert list(again.points["delta"]) == list(result.points["delta"])


@pytest.mark.parametrize("forged", [
    {"feasible": False, "status": "optimal", "delta": 1e-6, "ratio": 5.0},
    {"status": "garbage"},
    {"feasible": False, "status": "infeasible", "design": {}, "delta": None, "ratio": None},
], ids=["not feasible yet optimal", "unknown status", "feasible point said infeasible"])
def test_a_record_that_is_not_a_feasible_optimum_is_solved_again(small_front, small_path,
                                                                   tmp_path, forged):
    """Only a feasible design can be checked exactly; any other record (a forged verdict, a
    status that is none) is solved again, so it never becomes the knee or hides a point."""
    result, _ = small_front
    folder, lines = _copy(small_front, tmp_path)
    number = next(i for i, line in enumerate(lines, 1)
                  if i > 1 and json.loads(line).get("feasible")
                  and json.loads(line)["kind"] == "sweep")
    _edit(folder, lines, number, lambda r: r.update(forged))
    again = sweep(load_problem(small_path), folder, workers=1, resume=True, progress=False)
    assert again.run["resumed_points"] == len(lines) - 2
    assert again.indicators["knee"] == result.indicators["knee"]
    assert list(again.points["delta"]) == list(result.points["delta"])
    assert set(again.points["status"]) <= {"optimal", "local", "infeasible", "failed"}

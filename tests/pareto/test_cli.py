"""``optdesign pareto``: exit codes and every bad ``pareto:`` input named by file and key."""
import pytest

from optdesign.cli import main

from .conftest import small


@pytest.mark.parametrize("pareto, message", [
    ({"points": 1}, "small.yaml: pareto.points must be at least 2 (got 1)"),
    ({"points": 2.5}, "small.yaml: pareto.points must be a whole number (got 2.5)"),
    ({"points": 5000}, "small.yaml: pareto.points must be at most 1000 (got 5000)"),
    ({"ratio_lower": -0.1}, "small.yaml: pareto.ratio_lower must be positive (got -0.1)"),
    ({"ratio_lower": 0.8, "ratio_upper": 0.7},
     "small.yaml: pareto.ratio_upper must exceed ratio_lower (got 0.7 <= 0.8)"),
    ({"counts": 4}, "small.yaml: pareto.counts must be a non-empty list of phase counts"),
    ({"counts": [6]}, "small.yaml: pareto.counts [6] not admissible for design.phases "
                      "(admissible: 4)"),
    ({"span": 1}, "small.yaml: pareto.span is not a known key; known: against, counts, "
                  "points, ratio_lower, ratio_upper, refine, resolution"),
    ({"resolution": {"housing_radius": 0.1}},
     "small.yaml: pareto.resolution.housing_radius is not a known key; known: delta, ratio"),
    ({"resolution": {"delta": 0}}, "small.yaml: pareto.resolution.delta must be positive "
                                   "(got 0)"),
    ({"refine": {"max_gap": 0}}, "small.yaml: pareto.refine.max_gap must be positive (got 0)"),
    ({"refine": {"max_points": -1}},
     "small.yaml: pareto.refine.max_points must be at least 0 (got -1)"),
    ({"refine": {"enable": False}}, "small.yaml: pareto.refine.enable is not a known key; "
                                    "did you mean enabled? known: enabled, "
                                    "hypervolume_gap, hypervolume_points, max_gap, "
                                    "max_points, max_turn_deg"),
    ({"refine": {"hypervolume_gap": 2}},
     "small.yaml: pareto.refine.hypervolume_gap must lie in (0, 1] (got 2)"),
])
def test_bad_pareto_section_exits_2_naming_the_key(write_problem, capsys, pareto, message):
    path = write_problem(small(**pareto), name="small.yaml")
    assert main(["pareto", str(path), "--out", str(path.parent / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"optdesign: {message}"


def test_pareto_section_must_be_a_mapping(write_problem, capsys):
    data = small()
    data["pareto"] = [1, 2]
    path = write_problem(data, name="small.yaml")
    assert main(["pareto", str(path)]) == 2
    assert capsys.readouterr().err.strip() == \
        "optdesign: small.yaml: pareto must be a mapping (got list)"


def test_usage_errors_exit_2(small_path, tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["pareto", str(small_path), "--points", "1"])
    assert exc.value.code == 2
    assert "--points: must be at least 2 (got 1)" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:
        main(["pareto", str(small_path), "--workers", "x"])
    assert exc.value.code == 2
    assert main(["pareto", str(tmp_path / "missing.yaml")]) == 2
    assert "missing.yaml: no such file" in capsys.readouterr().err
    assert main(["pareto", str(small_path), "--out", str(tmp_path / "none"), "--resume"]) == 2
    assert "nothing to resume" in capsys.readouterr().err


def test_resume_with_other_settings_is_refused(small_front, small_path, capsys):
    out = small_front[1]
    assert main(["pareto", str(small_path), "--out", str(out), "--resume", "--points", "3",
                 "--no-report"]) == 2
    assert "cannot resume, the run's settings changed (points)" in capsys.readouterr().err


def test_resume_of_a_finished_sweep_solves_nothing_and_exits_0(small_front, small_path,
                                                               capsys):
    out = small_front[1]
    before = (out / "points.jsonl").read_text()
    assert main(["pareto", str(small_path), "--out", str(out), "--resume", "--workers", "1",
                 "--no-report"]) == 0
    assert (out / "points.jsonl").read_text() == before
    assert "4 non-dominated over every phase count" in capsys.readouterr().out


def test_a_problem_without_feasible_designs_exits_1(write_problem, tmp_path, capsys):
    data = small()
    data["constraints"]["min_transmission_angle_deg"] = 80       # no four-bar transmits so well
    data["solver"] = {"starts": 1, "agree": 1, "max_iter": 30}
    path = write_problem(data, name="small.yaml")
    assert main(["pareto", str(path), "--out", str(tmp_path / "o"), "--workers", "1",
                 "--no-report"]) == 1
    assert "0 non-dominated" in capsys.readouterr().out

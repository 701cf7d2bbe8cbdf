"""A front says what it is: one design is no trade-off, a fixed design is no front, and the
report names what binds along the front and what limits the ratio."""
from optdesign.cli import main
from optdesign.fronts.indicators import indicators
from tests.conftest import ROOT


def test_one_design_has_no_hypervolume():
    ind = indicators([0.2], [0.5])
    assert ind["n_points"] == 1 and ind["hypervolume"] is None and ind["spacing"] is None
    two = indicators([0.2, 0.3], [0.5, 0.6])
    assert two["hypervolume"] > 0


def test_a_fixed_design_is_not_a_front(tmp_path, capsys):
    code = main(["pareto", str(ROOT / "problems" / "sharkov2022.yaml"), "--out",
                 str(tmp_path / "out")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1
    assert "sharkov2022.yaml: design:" in err[0] and "free length" in err[0]
    assert not (tmp_path / "out").exists()


def test_points_name_what_binds_and_the_report_what_limits_the_ratio(small_front, small_path):
    from optdesign.fronts.report import blocks
    from optdesign.problem.loader import load_problem

    result, _ = small_front
    ok = result.points[result.points["status"] == "optimal"]
    assert ok["binding"].str.contains("min_ratio").any()       # the ε bound along the sweep
    limits = [e for e in result.ends if e["kind"] == "largest_ratio" and
              e["status"] == "optimal"]
    assert limits and all(e["ratio_limited_by"] for e in limits)
    report = blocks(result, load_problem(small_path), {}, {})
    assert ("h2", "What limits the ratio") in report
    table = report[report.index(("h2", "What limits the ratio")) + 2]
    assert table[0] == "table" and [row[2] for row in table[2]] == \
        [e["ratio_limited_by"] for e in limits]

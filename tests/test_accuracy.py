"""optdesign bench accuracy and the accuracy report of solve results."""
import json

import pytest

from optdesign.analyses.accuracy import lse_figures, reference_figures
from optdesign.solver.accuracy import solve_accuracy
from optdesign.cli import main
from optdesign.evaluation.design import Design
from optdesign.problem.loader import load_problem
from tests.conftest import PAPER, ROOT


def test_bench_accuracy_json(capsys, tmp_path):
    code = main(["bench", "accuracy", "--quick", "--json", "--out", str(tmp_path)])
    out = json.loads(capsys.readouterr().out)
    assert code == 0
    methods = {r["method"] for r in out["rows"]}
    assert {"sampled", "exact", "surrogate", "lse"} <= methods
    for r in out["rows"]:
        assert {"method", "samples", "delta_error", "ratio_error", "time_s"} <= set(r)
    exact = [r for r in out["rows"] if r["method"] == "exact"]
    assert max(r["delta_error"] for r in exact) < 1e-12           # exact at any grid here
    sur = [r for r in out["rows"] if r["method"] == "surrogate"]
    assert max(r["delta_error"] for r in sur) < 1e-8             # hand-overs are exact
    assert (tmp_path / "accuracy.png").stat().st_size > 10_000
    assert (tmp_path / "accuracy.json").exists()


def test_bench_bad_problem_exit_2(capsys, tmp_path):
    assert main(["bench", "accuracy", str(tmp_path / "missing.yaml")]) == 2
    assert "no such file" in capsys.readouterr().err


def test_plain_log_sum_exp_is_worse_than_the_surrogate():
    """What the hand-over points buy: the plain LSE formulation errs by ~1e-2 in δ at ρ = 200."""
    d = Design("fourbar_converter", dict(PAPER))
    ref = reference_figures(d, "forward", 97.0).figures
    lse = lse_figures(d, "forward", 97.0, 90, 200.0)
    assert abs(lse.delta - ref.delta) > 5e-3


def test_solve_result_reports_accuracy():
    p = load_problem(ROOT / "problems" / "sharkov2022.yaml")
    from optdesign.solver import solve
    r = solve(p)
    acc = r.accuracy
    for key in ("verification", "nlp_samples", "nlp_smoothing",
                "verification_tolerance_angle_deg", "exact_error_estimate", "surrogate_gap",
                "transmission_angle_sample_gap_deg"):
        assert key in acc
    assert acc["exact_error_estimate"]["delta"] < 1e-12
    assert abs(acc["surrogate_gap"]) < 1e-8
    assert 0 <= acc["transmission_angle_sample_gap_deg"] < 0.1
    empty = solve_accuracy(p, None)
    assert empty["exact_error_estimate"] is None

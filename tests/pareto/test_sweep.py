"""The sweep on a small problem: every point verified exactly, the contract's columns, the
ε-constraint's multiplier as the local slope, the ends of the front, the report files."""
import json

import numpy as np
import pandas as pd
import pytest

from optdesign.fronts.sweep import grid
from optdesign.fronts.section import ParetoSection
from optdesign.problem.loader import load_problem
from optdesign.solver import verify
from tests.conftest import ROOT

CONTRACT = ["phases", "delta", "ratio", "l0", "l1", "l2", "l2_prime", "l3", "status"]


def test_every_point_is_feasible_by_the_exact_evaluator(small_front, small_path):
    result, out = small_front
    p = load_problem(small_path)
    df = pd.read_csv(out / "pareto.csv")
    assert list(df.columns[:9]) == CONTRACT
    assert len(df) == 4 and (df["status"] == "optimal").all()
    for _, row in df.iterrows():
        values = {k: row[k] for k in ("l0", "l1", "l2", "l2_prime", "l3")} | {"phases": 4}
        ver = verify(p, values)
        assert ver.feasible
        # pareto.csv keeps 10 significant digits: the exact δ to that precision
        assert ver.delta == pytest.approx(row["delta"], rel=1e-8)
        assert ver.ratio == pytest.approx(row["ratio"], rel=1e-8)
        assert row["pin_radius"] == pytest.approx(row["l2"] - row["l2_prime"])
        assert row["min_transmission_angle_deg"] >= 30 - 1e-3
    assert df["ratio"].is_monotonic_increasing and df["delta"].is_monotonic_increasing
    assert df["count_front"].all() and df["non_dominated"].all()      # a real trade-off


def test_ratio_bound_binds_and_its_multiplier_is_the_local_slope(small_front):
    """Interior points meet ratio = ε, and IPOPT's multiplier dδ/dε agrees with the front's
    finite-difference slope between neighbours to within the curvature over one step (30 %)."""
    df = small_front[0].points
    inner = df.iloc[1:-1]
    assert np.allclose(inner["ratio"], inner["epsilon"], rtol=1e-6)
    slopes = np.diff(df["delta"]) / np.diff(df["ratio"])
    for k, (_, row) in enumerate(inner.iterrows(), start=1):
        lo, hi = sorted((slopes[k - 1], slopes[k]))
        assert 0.7 * lo <= row["ratio_multiplier"] <= 1.3 * hi
    assert df.iloc[0]["ratio_multiplier"] == 0.0          # least ripple: ratio bound slack


def test_json_and_report_are_written(small_front, small_path):
    from optdesign.commands.files import write_report
    result, out = small_front
    data = json.loads((out / "pareto.json").read_text())
    assert data["indicators"]["n_points"] == 4
    assert data["indicators"]["reference_point_normalised"] == [1.1, 1.1]
    assert data["knee"]["phases"] == 4
    files = write_report(result, load_problem(small_path), out)
    names = {f.name for f in files}
    assert {"fronts.png", "lengths.png", "knee_mechanism.png", "knee_speeds.png", "report.md",
            "report.html"} <= names
    html = (out / "report.html").read_text()
    assert html.count("data:image/png;base64,") == 4 and "<img" in html
    md = (out / "report.md").read_text()
    assert "casadi" in md and "hypervolume" in md and "![fronts.png](fronts.png)" in md


def test_grid_clips_the_span_to_the_reachable_range():
    ends = {"least_ripple": {"ratio": 0.5}, "largest_ratio": {"ratio": 0.9}}
    assert grid(ParetoSection(), ends, 5).tolist() == pytest.approx([0.5, 0.6, 0.7, 0.8, 0.9])
    assert grid(ParetoSection(ratio_lower=0.7, ratio_upper=2.0), ends, 3).tolist() == \
        pytest.approx([0.7, 0.8, 0.9])
    assert len(grid(ParetoSection(ratio_lower=0.95), ends, 3)) == 0
    flat = {"least_ripple": {"ratio": 0.5}, "largest_ratio": {"ratio": 0.5}}
    assert grid(ParetoSection(), flat, 5).tolist() == [0.5]          # a one-point front


def test_chains_walk_away_from_the_nearer_end():
    from optdesign.fronts.sweep import _chains
    eps = np.linspace(0.5, 0.9, 8)
    assert _chains([1, 2, 3, 4, 5, 6], eps, 2) == [[1, 2, 3], [6, 5, 4]]
    eps = np.linspace(0.5, 0.9, 10)
    assert _chains(list(range(1, 9)), eps, 4) == [[1, 2], [3, 4], [6, 5], [8, 7]]
    assert _chains([], eps, 2) == []




def test_a_point_is_the_same_whatever_its_worker_solved_before():
    """A point's record, iterations and multiplier included, does not depend on what its
    worker process solved before it: each task solves on a solver of its own. (A worker kept
    its solver from task to task, and with it every NLP an earlier task had built: the
    slotted lever's largest-ratio end at n = 3 needs 12 hand-over slots where its other
    points need 6, and a point solved after it, in a worker that had built no other, took
    the 12-slot NLP and another path.)"""
    from dataclasses import replace

    from optdesign.fronts import worker

    problem = load_problem(ROOT / "problems" / "pareto_slotted_forward.yaml")
    low = worker.solve_end(problem, 3, "least_ripple")
    epsilon = 0.5 * (low["ratio"] + 1.0)

    def point(p):
        rec = worker.solve_point(p, 3, 1, epsilon, low["design"], [])
        assert rec["status"] == "optimal"
        return {k: v for k, v in rec.items() if k != "time_s"}

    # two copies of the problem (their names apart): each its own worker's, as it were
    alone = point(replace(problem, name="first_task"))
    after_the_end = replace(problem, name="after_the_end")
    high = worker.solve_end(after_the_end, 3, "largest_ratio")
    assert high["status"] == "optimal" and high["ratio"] > epsilon
    assert point(after_the_end) == alone

"""Global ε points, refinement and merging: the pure functions on hand-made fronts, the
screening's seeds, and one small sweep refined end to end (and resumed mid-refinement)."""
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from optdesign.fronts import sweep
from optdesign.fronts.refine import (MAX_ROUNDS, Refinement, gaps, merge_identical, plan,
                                     plan_hypervolume, superseded, visible)
from optdesign.fronts.seeds import RATIO_SLACK, ScreenedCount
from optdesign.fronts.store import Journal
from optdesign.fronts.worker import Candidate, best_candidate
from optdesign.problem.loader import problem_from_dict
from optdesign.solver import verify

from .conftest import small

LENGTHS = ["l1", "l3"]


def rec(i, ratio, delta, mult=None, eps=None, design=None, kind="sweep", rnd=0,
        replaces=None, feasible=True):
    """A journal record of count 4 at grid index ``i`` (its design made from its figures)."""
    out = {"key": [4, i], "count": 4, "phases": 4, "kind": kind, "feasible": feasible,
           "status": "optimal" if feasible else "failed",
           "epsilon": ratio if eps is None else eps,
           "delta": delta if feasible else None, "ratio": ratio if feasible else None,
           "ratio_multiplier": mult, "round": rnd,
           "design": design or {"l1": 100 * ratio, "l3": 30 + 100 * delta, "phases": 4}}
    if replaces is not None:
        out["replaces"] = replaces
    return out


def kinked(step=0.02):
    """A front flat up to ratio 0.86 (slope 0.05), then steep (slope 4): ε every 0.02."""
    out = []
    for i, r in enumerate(np.arange(0.70, 0.92 + 1e-9, step)):
        flat = r <= 0.86 + 1e-9
        d = 0.1 + 0.05 * (min(r, 0.86) - 0.7) + (0 if flat else 4 * (r - 0.86))
        out.append(rec(i, float(r), float(d), 0.05 if flat else 4.0))
    return out


# --------------------------------------------------------------------------- (a) refinement
def test_refinement_puts_points_into_the_jump_not_on_the_flat_stretch():
    front = kinked()
    tasks = plan(front, LENGTHS, Refinement(max_gap=0.1, max_points=24), first_index=20)
    eps = [t.epsilon for t in tasks]
    assert eps and all(0.86 < e < 0.92 for e in eps)          # none on the flat stretch
    assert any(0.86 < e < 0.88 for e in eps)                  # inside the kink's gap
    assert [t.index for t in tasks] == list(range(20, 20 + len(tasks)))
    # where the slope turns, both neighbours are polished; on one stretch the lower alone
    kink = next(t for t in tasks if t.epsilon < 0.88)
    steep = next(t for t in tasks if t.epsilon > 0.88)
    assert kink.also and not steep.also
    # the budget: the longest gaps first, never more than max_points
    assert len(plan(front, LENGTHS, Refinement(max_gap=0.1, max_points=3), 20)) == 3
    assert plan(front, LENGTHS, Refinement(enabled=False), 20) == []
    # a budget already spent by earlier rounds
    done = front + [rec(20 + k, r, 0.108 + 4 * (r - 0.86), 4.0, rnd=1)
                    for k, r in enumerate((0.87, 0.89, 0.91))]
    assert plan(done, LENGTHS, Refinement(max_gap=0.1, max_points=3), 30) == []


def test_a_smooth_evenly_spaced_front_is_not_refined():
    front = [rec(i, 0.7 + 0.02 * i, 0.1 + 0.02 * i, 1.0) for i in range(12)]
    assert plan(front, LENGTHS, Refinement(max_gap=0.2), 12) == []


def test_a_gap_where_the_front_jumps_is_narrowed_then_left_alone():
    """ε tried inside a gap that lands on the upper neighbour: the front jumps between the
    lower neighbour and that ε, so only that interval is refined, and once it is narrow the
    gap is settled."""
    a, b = rec(0, 0.80, 0.10, 0.1), rec(1, 0.90, 0.50, 0.1)
    landed = rec(2, 0.90, 0.50, 0.1, eps=0.85, design=dict(b["design"]), rnd=1)
    settings = Refinement(max_gap=0.1, max_points=24)
    first = plan([a, b], LENGTHS, settings, 2)
    assert first and all(0.80 < t.epsilon < 0.90 for t in first)
    again = plan([a, b, landed], LENGTHS, settings, 3)
    assert again and all(0.80 < t.epsilon < 0.85 for t in again)
    tight = rec(2, 0.90, 0.50, 0.1, eps=0.801, design=dict(b["design"]), rnd=1)
    assert plan([a, b, tight], LENGTHS, settings, 3) == []
    found = gaps([a, b], [a, b, landed], settings)
    assert len(found) == 1 and found[0].hi == pytest.approx(0.85)


def _on(count, i, ratio, delta, **kw):
    """A record of ``count`` (``rec`` makes count 4)."""
    r = rec(i, ratio, delta, **kw)
    r["key"], r["count"], r["design"]["phases"] = [count, i], count, count
    return r


def test_hypervolume_rounds_fill_the_largest_uncovered_areas_across_counts():
    """Two counts whose fronts cross: n = 6 best up to ratio 0.80, n = 4 beyond. The gap
    that leaves the largest rectangle (Δratio·Δδ, normalised) gets the most new ε values, an
    evenly covered stretch none, and where the front changes count both counts are tried."""
    six = [_on(6, i, r, d, mult=0.5) for i, (r, d) in
           enumerate([(0.70, 0.10), (0.72, 0.11), (0.74, 0.12), (0.76, 0.13), (0.78, 0.14),
                      (0.80, 0.15)])]
    four = [_on(4, i, r, d, mult=2.0) for i, (r, d) in
            enumerate([(0.78, 0.20), (0.90, 0.40), (1.00, 0.90)])]
    settings = Refinement(hypervolume_gap=1e-3, hypervolume_points=40)
    tasks = plan_hypervolume(six + four, LENGTHS, settings, least_index=10)
    assert tasks and len(tasks) <= 40
    eps = {n: sorted(t.task.epsilon for t in tasks if t.count == n) for n in (4, 6)}
    assert not any(0.70 < e < 0.80 for e in eps[6] + eps[4])      # evenly covered: no ε
    assert any(0.80 < e < 0.90 for e in eps[6])                   # the count changes: six too
    assert any(0.80 < e < 0.90 for e in eps[4])
    big = sum(0.90 < e < 1.00 for e in eps[4])                    # rectangle 0.33 × 0.63
    small = sum(0.80 < e < 0.90 for e in eps[4])                  # rectangle 0.33 × 0.31
    assert big > small >= 1
    for n, first in ((4, 10), (6, 10)):                           # numbered past the records
        assert sorted(t.task.index for t in tasks if t.count == n) == \
            list(range(first, first + len(eps[n])))
    # the budget bounds every hypervolume round together; spent, nothing more
    assert len(plan_hypervolume(six + four, LENGTHS, Refinement(
        hypervolume_gap=1e-3, hypervolume_points=5), 10)) <= 5
    spent = [_on(4, 10 + k, 0.92 + 0.01 * k, 0.45 + 0.05 * k, rnd=MAX_ROUNDS + 1)
             for k in range(5)]
    assert plan_hypervolume(six + four + spent, LENGTHS, Refinement(
        hypervolume_gap=1e-3, hypervolume_points=5), 10) == []
    assert plan_hypervolume(six + four, LENGTHS, Refinement(hypervolume_points=0), 10) == []


def test_a_hypervolume_gap_where_a_count_jumps_is_not_tried_again():
    """An ε of n = 4 inside a gap that landed on the upper neighbour (the front jumps): the
    gap shrinks to below that ε and, once its rectangle is small, is left alone; one that
    landed inside (a point dominated there) or failed closes the gap for that count."""
    a, b = _on(4, 0, 0.80, 0.10, mult=0.1), _on(4, 1, 0.90, 0.50, mult=0.1)
    settings = Refinement(hypervolume_gap=1e-3, hypervolume_points=40)
    first = plan_hypervolume([a, b], LENGTHS, settings, 2)
    assert first and all(0.80 < t.task.epsilon < 0.90 for t in first)
    landed = _on(4, 2, 0.90, 0.50, mult=0.1, eps=0.82, design=dict(b["design"]),
                 rnd=MAX_ROUNDS + 1)
    again = plan_hypervolume([a, b, landed], LENGTHS, settings, 3)
    assert again and all(0.80 < t.task.epsilon < 0.82 for t in again)
    tight = dict(landed, epsilon=0.8001)
    assert plan_hypervolume([a, b, tight], LENGTHS, settings, 3) == []
    failed = _on(4, 2, 0.0, 0.0, eps=0.85, feasible=False, rnd=MAX_ROUNDS + 1)
    assert plan_hypervolume([a, b, failed], LENGTHS, settings, 3) == []


def test_a_hypervolume_gap_is_filled_when_its_lower_end_meets_its_own_bound_to_the_tolerance():
    """IPOPT holds a point's ratio bound to its tolerance: the design's ratio may lie a hair
    below its own ε. That ε is the lower end's problem, not an ε inside the gap that landed
    there (a dominated point), so the gap is refined as if the bound held to the bit."""
    b = _on(4, 1, 0.90, 0.50, mult=0.1)
    settings = Refinement(hypervolume_gap=1e-3, hypervolume_points=40)
    exact = plan_hypervolume([_on(4, 0, 0.80, 0.10, mult=0.1), b], LENGTHS, settings, 2)
    short = _on(4, 0, 0.80, 0.10, mult=0.1, eps=0.80 + 2e-11)
    assert exact and plan_hypervolume([short, b], LENGTHS, settings, 2) == exact


# --------------------------------------------------------------------------- (b) merging
def test_identical_designs_are_merged_into_one_row():
    d = {"l1": 25.0, "l3": 30.0, "phases": 4}
    twin = {"l1": 25.0 * (1 + 1e-6), "l3": 30.0, "phases": 4}
    other = {"l1": 25.1, "l3": 30.0, "phases": 4}
    rows = [rec(0, 0.8, 0.2, 0.0, kind="least_ripple", design=d),
            rec(1, 0.8, 0.2, 0.0, eps=0.79, design=twin),
            rec(2, 0.8, 0.2, 0.0, eps=0.795, design=dict(d)),
            rec(3, 0.81, 0.21, 0.1, design=other),
            rec(4, 0.0, 0.0, eps=0.85, feasible=False)]
    out = merge_identical(rows, LENGTHS)
    assert [r["key"][1] for r in out] == [0, 3, 4]       # the end kept, the failed one too
    assert out[0]["merged"] == 2 and out[1]["merged"] == 0
    # of sweep points, the one of largest ε (where the bound binds) stands for the others
    out = merge_identical(rows[1:3], LENGTHS)
    assert [r["key"][1] for r in out] == [2] and out[0]["merged"] == 1
    # another phase count is another design
    six = rec(5, 0.8, 0.2, design=dict(d)) | {"count": 6, "key": [6, 5]}
    assert len(visible(rows[:1] + [six], LENGTHS)) == 2


# --------------------------------------------------------------------------- (c) global
def _cand(delta, source, feasible=True):
    outcome = SimpleNamespace(record=SimpleNamespace(feasible=feasible),
                              verification=SimpleNamespace(delta=delta))
    return Candidate(outcome, source)


def test_the_best_verified_start_wins_and_the_chain_keeps_a_tie():
    chain, seed = _cand(0.30, "chain"), _cand(0.20, "screening")
    assert best_candidate([chain, seed, _cand(0.1, "screening", False)]) is seed
    assert best_candidate([chain, _cand(0.30 * (1 - 1e-9), "screening")]) is chain
    assert best_candidate([_cand(0.1, "chain", False)]) is None


def test_a_dominated_chain_point_is_re_solved_from_the_design_dominating_it():
    """A non-convex front: the chain followed a branch that a later point beats; the point
    is re-solved at its ε from the dominating design, and the re-solve takes its place."""
    front = [rec(0, 0.70, 0.10, 0.0), rec(1, 0.75, 0.14, 0.8),
             rec(2, 0.80, 0.30, 3.0),          # the chain's branch, dominated by point 3
             rec(3, 0.85, 0.25, 0.5), rec(4, 0.90, 0.40, 3.0)]
    tasks = plan(front, LENGTHS, Refinement(enabled=False), 5)
    assert [(t.replaces, t.index, t.epsilon) for t in tasks] == [(2, 5, 0.80)]
    assert tasks[0].start == front[3]["design"]
    better = rec(5, 0.80, 0.18, 0.6, rnd=1, replaces=2)
    shown = superseded(front + [better])
    assert [r["key"][1] for r in shown] == [0, 1, 3, 4, 5]
    worse = rec(5, 0.80, 0.35, 0.6, rnd=1, replaces=2)
    assert [r["key"][1] for r in superseded(front + [worse])] == [0, 1, 2, 3, 4]
    # one re-solve per point: not planned again whatever it gave
    assert plan(front + [worse], LENGTHS, Refinement(enabled=False), 6) == []


def test_the_screening_seeds_reach_epsilon_and_skip_the_chains_basin():
    problem = problem_from_dict(small(), where="small.yaml")
    screened = ScreenedCount.of(problem, 4)
    eps = 0.83
    seeds = screened.seeds(eps, 3)
    assert seeds
    for s in seeds:
        i = next(j for j, v in enumerate(screened.values) if v == s)
        assert screened.feasible[i] and screened.ratio[i] >= eps * (1 - RATIO_SLACK)
    assert seeds[0] not in screened.seeds(eps, 3, near=[seeds[0]])
    assert screened.seeds(10.0, 3) == []                 # no screened design reaches it


# --------------------------------------------------------------------------- end to end
def _gap(df):
    r, d = df["ratio"].to_numpy(), df["delta"].to_numpy()
    return float(np.max(np.hypot(np.diff(r) / np.ptp(r), np.diff(d) / np.ptp(d))))


def test_a_refined_sweep_is_verified_merged_and_resumes_mid_refinement(tmp_path):
    problem = problem_from_dict(small(refine={"max_points": 4, "hypervolume_points": 0}),
                                where="small.yaml")
    out = tmp_path / "full"
    df = sweep(problem, out, workers=1, progress=False).points
    assert (df["status"] == "optimal").all() and len(df) == 4 + 4
    refined = df[df["round"] >= 1]
    assert len(refined) == 4
    uniform = df[df["round"] == 0]
    assert _gap(df) < 0.6 * _gap(uniform)                # the largest gap shrank
    assert df["ratio"].is_monotonic_increasing and df["count_front"].all()
    for _, row in refined.iterrows():
        assert row["ratio"] == pytest.approx(row["epsilon"], rel=1e-6)      # ε binds
        ver = verify(problem, {k: row[k] for k in ("l0", "l1", "l2", "l2_prime", "l3")}
                     | {"phases": 4})
        assert ver.feasible and ver.delta == pytest.approx(row["delta"], rel=1e-8)
    designs = df[["l1", "l3"]].round(6).drop_duplicates()
    assert len(designs) == len(df)                       # one row a design
    header, records = Journal(out / "points.jsonl").read()
    keys = [tuple(r["key"]) for r in records]
    assert len(keys) == len(set(keys))
    assert {k[1] for k in keys if isinstance(k[1], int) and k[1] >= 4} == {4, 5, 6, 7}

    # killed after the first refined point: the journal holds the rest up to it
    lines = (out / "points.jsonl").read_text().splitlines(keepends=True)
    cut = next(i for i, line in enumerate(lines) if '"round": 1' in line) + 1
    again = tmp_path / "again"
    again.mkdir()
    (again / "points.jsonl").write_text("".join(lines[:cut]))
    resumed = sweep(problem, again, workers=1, resume=True, progress=False).points
    after = Journal(again / "points.jsonl").read()[1]
    assert after[:cut - 1] == records[:cut - 1]                       # nothing rewritten
    assert sorted(map(str, (tuple(r["key"]) for r in after))) == sorted(map(str, keys))
    assert resumed["epsilon"].to_numpy() == pytest.approx(df["epsilon"].to_numpy(), rel=1e-12)
    assert resumed["delta"].to_numpy() == pytest.approx(df["delta"].to_numpy(), rel=1e-6)
    assert isinstance(pd.read_csv(again / "pareto.csv")["round"].iloc[0], np.integer)


def test_hypervolume_rounds_add_verified_points_and_resume_alike(tmp_path):
    """The small front with the hypervolume rounds on (budget 4): rounds ≥ 5 add at most 4
    verified points where the refined front left the largest areas, the hypervolume on one
    normalisation does not fall, and a run killed after the first of them resumes to the
    same ε values."""
    from optdesign.fronts.indicators import hypervolume_2d, non_dominated, normalise, objectives

    settings = {"max_points": 2, "hypervolume_points": 4, "hypervolume_gap": 1e-3}
    problem = problem_from_dict(small(refine=settings), where="small.yaml")
    out = tmp_path / "full"
    df = sweep(problem, out, workers=1, progress=False).points
    late = df[df["round"] > MAX_ROUNDS]
    assert 1 <= len(late) <= 4 and (df["status"] == "optimal").all()
    for _, row in late.iterrows():
        ver = verify(problem, {k: row[k] for k in ("l0", "l1", "l2", "l2_prime", "l3")}
                     | {"phases": 4})
        assert ver.feasible and ver.delta == pytest.approx(row["delta"], rel=1e-8)
    f_all = objectives(df["delta"], df["ratio"])
    f_before = objectives(df[df["round"] <= MAX_ROUNDS]["delta"],
                          df[df["round"] <= MAX_ROUNDS]["ratio"])
    z_all, ideal, nadir = normalise(f_all[non_dominated(f_all)])
    z_before = normalise(f_before[non_dominated(f_before)], ideal, nadir)[0]
    assert hypervolume_2d(z_all) >= hypervolume_2d(z_before) - 1e-12

    lines = (out / "points.jsonl").read_text().splitlines(keepends=True)
    cut = next(i for i, line in enumerate(lines)
               if f'"round": {MAX_ROUNDS + 1}' in line) + 1
    again = tmp_path / "again"
    again.mkdir()
    (again / "points.jsonl").write_text("".join(lines[:cut]))
    resumed = sweep(problem, again, workers=1, resume=True, progress=False).points
    assert resumed["epsilon"].to_numpy() == pytest.approx(df["epsilon"].to_numpy(), rel=1e-12)


def test_a_dominated_point_of_a_real_sweep_is_re_solved_and_none_is_left(tmp_path,
                                                                        monkeypatch):
    """The disc problem's six-phase count: with the solve held to its two best-ranked basins
    (the rule that polishes on where they end apart switched off, as a solve that stops early
    would), its least-ripple end lands on a local optimum (δ 0.1463 at ratio 0.568) that a
    design found along the chains dominates (δ 0.1417 at ratio 0.738). The re-solve from the
    dominating design replaces it; no dominated row is left and the designs that coincide are
    one row."""
    import yaml

    from optdesign.solver import polishing

    monkeypatch.setattr(polishing.Polishing, "apart", lambda self: False)

    from tests.conftest import ROOT

    data = yaml.safe_load((ROOT / "problems" / "pareto_disc_three_counts.yaml").read_text())
    data["pareto"] = {"points": 4, "counts": [6], "refine": {"enabled": False}}
    problem = problem_from_dict(data, where="disc.yaml")
    df = sweep(problem, tmp_path, workers=1, progress=False).points
    records = Journal(tmp_path / "points.jsonl").read()[1]
    grid = [r for r in records if isinstance(r["key"][1], int) and r["feasible"]]
    resolved = {r["replaces"] for r in grid if r.get("replaces") is not None}
    beaten = {r["key"][1] for r in grid
              if any(q["delta"] < r["delta"] * (1 - 1e-6) and q["ratio"] >= r["ratio"]
                     for q in grid if q.get("replaces") is None)}
    assert beaten, "the two-basin solve found the best end: the case no longer tests this"
    assert beaten <= resolved                              # each dominated point re-solved
    assert all(r["start_from"] == "dominating" for r in grid if r.get("replaces") is not None)
    assert (df["status"] == "optimal").all() and df["count_front"].all()
    assert len(df[["l0", "l2", "l3"]].round(4).drop_duplicates()) == len(df)
    assert df["merged"].sum() == len(grid) - len(df) - len(resolved)

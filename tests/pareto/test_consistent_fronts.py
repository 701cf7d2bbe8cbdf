"""Fronts a designer can trust: no point called optimal that a known design beats on its own
ε-problem, no points closer than the designer's resolution, an honest knee.

The synthetic fronts below are journal records (optdesign.fronts.refine works on records
alone); the front that turns back is the one a designer met: n = 8, the ratio's interior
points of a few 1e-4 of δ more than the largest-ratio end, which reaches every one of their ε.
"""
import numpy as np
import pytest

from optdesign.fronts.front import evaluate, frame
from optdesign.fronts.indicators import indicators
from optdesign.fronts.refine import (LOCAL, Refinement, beater, gaps, plan, plan_hypervolume,
                                     visible)

from .test_refinement import LENGTHS, rec


def turned_back():
    """A count whose sweep found a low branch up to ratio 0.595 (δ 0.1047 -> 0.10516) and
    three interior points (ε 0.60-0.62) on a worse local branch, while its largest-ratio end
    (0.689, δ 0.105223) meets all three with less ripple."""
    out = [rec(i, float(r), float(0.1047 + 0.0169 * (r - 0.568)), eps=float(r))
           for i, r in enumerate(np.linspace(0.568, 0.595, 6))]
    out += [rec(6, 0.6010, 0.105245), rec(7, 0.6065, 0.105328), rec(8, 0.6175, 0.105469)]
    out.append(rec(9, 0.689169, 0.105223, kind="largest_ratio"))
    return out


def test_a_point_beaten_on_its_own_epsilon_is_local_not_optimal():
    records = turned_back()
    end = records[-1]
    for p in records[6:9]:
        assert beater(p, records) is end
    assert all(beater(p, records) is None for p in records[:6])
    shown = visible(records, LENGTHS)
    status = {r["key"][1]: r["status"] for r in shown}
    assert [status[i] for i in (6, 7, 8)] == [LOCAL] * 3
    assert all(status[i] == "optimal" for i in range(6)) and status[9] == "optimal"
    # the CSV keeps them, and they still count as verified designs of the front
    points = frame(shown, LENGTHS)
    assert (points["status"] == LOCAL).sum() == 3
    overall, _ = evaluate(points)
    assert overall["n_points"] >= 2


def test_every_beaten_point_is_re_solved_from_the_design_that_beats_it():
    records = turned_back()
    tasks = plan(records, LENGTHS, Refinement(enabled=False), first_index=10)
    assert sorted(t.replaces for t in tasks) == [6, 7, 8]
    assert all(t.start == records[-1]["design"] for t in tasks)
    assert [t.epsilon for t in sorted(tasks, key=lambda t: t.replaces)] == \
        [r["epsilon"] for r in records[6:9]]
    # a re-solve that ends on the beating design replaces the point: nothing is local then
    done = records + [rec(10 + k, 0.689169, 0.105223, eps=records[6 + k]["epsilon"],
                          replaces=6 + k, rnd=1, design=records[-1]["design"])
                      for k in range(3)]
    assert not any(r["status"] == LOCAL for r in visible(done, LENGTHS))
    # a hypervolume round re-solves what a later design beats, before it adds points
    late = records[:6] + [records[9]] + [rec(20, 0.640, 0.1060, rnd=5)]
    hv = plan_hypervolume(late, LENGTHS, Refinement(), least_index=12)
    assert hv and hv[0].task.replaces == 20 and hv[0].task.start == records[9]["design"]


def test_no_point_goes_between_neighbours_closer_than_the_resolution():
    """The uniform pass put neighbours 0.0054 of ratio and 1e-4 of δ apart: a normalised gap
    of 0.2 that the old rule refined, nothing a designer can read."""
    records = turned_back()[:6] + [turned_back()[-1]]
    coarse = Refinement(max_gap=0.1, delta_resolution=1e-4, gain_resolution=1e-2)
    found = gaps(records, records, coarse)
    assert [(round(g.lower["ratio"], 3), round(g.upper["ratio"], 3)) for g in found] == \
        [(0.595, 0.689)]                     # only the long stretch is worth a point
    tasks = plan(records, LENGTHS, coarse, first_index=10)
    eps = sorted(t.epsilon for t in tasks if t.replaces is None)
    assert eps and all(0.595 < e < 0.689 for e in eps)
    assert np.min(np.diff([0.595] + eps + [0.689])) >= 1e-2     # each part above resolution
    fine = Refinement(max_gap=0.1, delta_resolution=1e-6, gain_resolution=1e-5)
    assert len(gaps(records, records, fine)) > 1


def test_a_flat_front_recommends_its_best_end():
    delta = [0.10475, 0.10480, 0.10490, 0.10500]
    ratio = [0.568, 0.60, 0.65, 0.689]
    flat = indicators(delta, ratio, flat_below=1e-3)
    assert flat["flat"] and flat["knee"] == 3                    # the largest ratio
    steep = indicators(delta, ratio, flat_below=1e-5)
    assert not steep["flat"]
    assert indicators([0.1, 0.2], [0.5, 0.6], flat_below=1.0)["knee"] == 1


@pytest.mark.parametrize("a,b,parts", [((0.5, 0.10), (0.6, 0.10), 100),
                                       ((0.5, 0.10), (0.5004, 0.10005), 0),
                                       ((0.5, 0.10), (0.5, 0.1003), 3)])
def test_the_resolution_counts_the_parts_a_stretch_can_take(a, b, parts):
    settings = Refinement(delta_resolution=1e-4, gain_resolution=1e-3)
    assert settings.resolvable(rec(0, *a), rec(1, *b)) == parts


def test_the_report_says_where_the_front_jumps_and_why():
    from optdesign.fronts.front import ParetoResult
    from optdesign.fronts.report import jumps, knee_reason

    shown = visible(turned_back()[:6] + [turned_back()[-1]], LENGTHS)
    points = frame(shown, LENGTHS)
    overall, per_count = evaluate(points, flat_below=1e-4)
    result = ParetoResult(points, overall, per_count, run={})
    (row,) = jumps(result)
    assert row[:2] == ["0.595", "0.68917"] and "branch" in row[-1]
    text = knee_reason(result)
    # on the values' own scales δ moves by 0.5 % while the ratio moves by 21 %: the design of
    # the most ratio per unit of ripple is the largest-ratio end, and the report says why
    assert result.knee["ratio"] == pytest.approx(0.689169)
    assert "(δ by 0.5 %, ratio by 21.3 %)" in text and "ratio/δ largest" in text
    # flat at a coarser resolution: the knee is the largest-ratio end, and it says so
    overall, per_count = evaluate(points, flat_below=1e-3)
    flat = ParetoResult(points, overall, per_count, run={"refine": {"delta_resolution": 1e-3}})
    assert flat.knee["ratio"] == pytest.approx(0.689169)
    assert knee_reason(flat).startswith("The front is flat: δ is the same within 0.001")

"""Which counts a solve polishes (optdesign/solver/count_order.py): the ripple problems of
several counts in a box under two decades rank their counts by promise and leave out those
far behind the least δ found; the answer is the one every count polished gives. About 6 s."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from optdesign.problem.loader import load_problem
from optdesign.solver import count_order, solve
from optdesign.solver.screening import promise, screen

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def free_design():
    return load_problem(ROOT / "problems" / "free_design.yaml")


@pytest.fixture(scope="module")
def ranked_answer(free_design):
    return solve(free_design)


def test_the_far_counts_are_outranked_and_said_so(free_design, ranked_answer):
    result = ranked_answer
    assert result.status == "optimal"
    assert result.design["phases"] == 8
    assert result.delta == pytest.approx(0.0842474, abs=2e-7)
    statuses = {p.count: p.status for p in result.per_phase}
    assert statuses == {4: "outranked", 5: "optimal", 6: "optimal", 7: "optimal",
                        8: "optimal"}
    assert [p.count for p in result.per_phase] == [4, 5, 6, 7, 8]      # in increasing order
    for p in result.per_phase[:1]:
        assert p.screening["promise"] > (1 + count_order.MARGIN) * result.delta
        assert p.iterations == 0 and not p.starts
        assert "not polished" in p.message and "phases = 8" in p.message
        assert f"{p.screening['promise']:.6g}" in p.message
    out = json.loads(json.dumps(result.to_dict()))
    assert out["per_phase"][0]["status"] == "outranked"


def test_every_count_polished_gives_the_same_answer(free_design, ranked_answer, monkeypatch):
    """The rule changes which counts are polished, not the answer (the same order)."""
    margin = count_order.MARGIN
    monkeypatch.setattr(count_order, "MARGIN", math.inf)
    every = solve(free_design)
    assert [p.status for p in every.per_phase] == ["optimal"] * 5
    assert every.design["phases"] == ranked_answer.design["phases"]
    assert every.delta == pytest.approx(ranked_answer.delta, rel=1e-9)
    assert every.iterations > ranked_answer.iterations
    # every outranked count's optimum is indeed worse than the answer, by the margin
    for p in every.per_phase:
        if p.count == 4:
            assert p.delta > (1 + margin) * ranked_answer.delta


def test_the_counts_are_ranked_only_where_it_was_measured(free_design):
    assert count_order.ranks(free_design)
    wide = free_design.with_bounds(l3=(1.0, 1000.0))                  # three decades
    assert not count_order.ranks(wide)
    ratio = load_problem(ROOT / "problems" / "pulse_reducer_solve.yaml")   # -ratio
    assert len(ratio.counts()) > 1 and not count_order.ranks(ratio)
    robust = load_problem(ROOT / "problems" / "robust_fourbar.yaml").with_design(
        phases={"lower": 4, "upper": 8})
    assert len(robust.counts()) > 1 and not count_order.ranks(robust)    # a tolerance box
    one = load_problem(ROOT / "problems" / "sharkov2022_disc.yaml")
    assert not count_order.ranks(one)
    assert count_order.ranked(one) == [(6, None)]
    # unranked: every count in increasing order, none left out
    assert [n for n, _ in count_order.ranked(ratio)] == ratio.counts()


def test_ranked_by_promise(free_design):
    order = count_order.ranked(free_design)
    promises = [s.promise for _, s in order]
    assert promises == sorted(promises)
    assert [n for n, _ in order] == [8, 7, 6, 5, 4]


def test_nothing_is_outranked_without_an_optimum(free_design):
    scored = promise(free_design, 4, free_design.solver.screen)
    assert not count_order.outranked(free_design, scored, None)


@pytest.mark.parametrize("count", [4, 8])
def test_the_screening_given_its_promise_is_the_same(free_design, count):
    """The promise's scores stand for the screening's own: the same candidates, seeds and
    missed shares; with a neighbour to add, the screening scores its rows itself."""
    n = free_design.solver.screen
    scored = promise(free_design, count, n)
    for extra in ([], [free_design.start_values() | {"l3": 40.0}]):
        plain = screen(free_design, count, n, extra=extra)
        given = screen(free_design, count, n, extra=extra, scored=scored)
        assert [(c.values, c.score, c.feasible, c.objective) for c in plain.candidates] == \
            [(c.values, c.score, c.feasible, c.objective) for c in given.candidates]
        assert [c.values for c in plain.seeds] == [c.values for c in given.seeds]
        assert plain.missed == given.missed and plain.radius == given.radius
    assert np.isfinite(scored.promise)

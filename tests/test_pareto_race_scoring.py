"""The scoring of benchmarks/pareto_vs_peers.py (benchmarks/pareto_scoring.py) on tiny cases
whose answers are known by hand: the common normalisation, moocore's hypervolume, the
domination margin, the checkpoints and the thinning of an archive."""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("pareto_scoring",
                                               ROOT / "benchmarks" / "pareto_scoring.py")
scoring = importlib.util.module_from_spec(_spec)
sys.modules[_spec.name] = scoring          # dataclasses look their module up there
_spec.loader.exec_module(scoring)


def test_normalisation_spans_the_non_dominated_union_of_every_front():
    ours = scoring.objectives([1.0, 2.0], [2.0, 3.0])
    peer = scoring.objectives([1.5, 3.0], [2.5, 1.0])     # (3.0, 1.0) is dominated by ours
    norm = scoring.Normalisation.of_fronts([ours, peer])
    assert norm.ideal == (1.0, -3.0)
    assert norm.nadir == (2.0, -2.0)                       # the dominated point is left out
    np.testing.assert_allclose(norm.normalise(ours), [[0, 1], [1, 0]])


def test_hypervolume_of_a_known_staircase():
    """z = (0, 1), (0.25, 0.25), (1, 0) against (1.1, 1.1): the staircase sum
    0.25·0.1 + 0.75·0.85 + 0.1·1.1 = 0.7725, exact in binary to 1e-15."""
    norm = scoring.Normalisation((1.0, -3.0), (2.0, -2.0))
    f = scoring.objectives([1.0, 1.25, 2.0], [2.0, 2.75, 3.0])
    assert norm.hypervolume(f) == pytest.approx(0.7725, abs=1e-12)
    beyond = np.vstack([f, scoring.objectives([5.0], [0.0])])  # past the reference point
    assert norm.hypervolume(beyond) == pytest.approx(0.7725, abs=1e-12)
    assert norm.hypervolume(f[[0, 2]]) == pytest.approx(0.21, abs=1e-12)
    assert norm.hypervolume(np.zeros((0, 2))) == 0.0
    from optdesign.fronts.indicators import hypervolume_2d
    assert norm.hypervolume(f) == pytest.approx(hypervolume_2d(norm.normalise(f)), abs=1e-12)


def _pt(n, delta, ratio):
    return {"phases": n, "delta": delta, "ratio": ratio}


def test_domination_margin_at_equal_or_higher_ratio():
    ours = [_pt(4, 0.20, 0.80), _pt(6, 0.10, 0.70)]
    peer = [_pt(6, 0.09, 0.75)]            # beats our n = 6 point, not the n = 4 one (ratio)
    m = scoring.domination_margin(ours, peer)
    assert m["margin"] == pytest.approx(0.01) and m["relative"] == pytest.approx(0.1)
    assert m["ours"] == _pt(6, 0.10, 0.70)
    assert scoring.domination_margin(ours, peer, same_count=True)["margin"] == \
        pytest.approx(0.01)
    assert scoring.format_margin(m).startswith("**+1.0e-02**")
    worse = [_pt(4, 0.25, 0.85)]           # higher ratio, higher δ: no domination
    m = scoring.domination_margin(ours, worse)
    assert m["margin"] == pytest.approx(-0.05) and scoring.format_margin(m) == "none (-5.0e-02)"
    assert scoring.domination_margin(ours[1:], worse, same_count=True) is None
    assert scoring.domination_margin(ours, [_pt(6, 0.01, 0.5)]) is None   # ratio too low
    assert scoring.format_margin(None) == "no pair"


def test_checkpoints_are_log_spaced_and_hold_our_time():
    times = scoring.checkpoint_times(2.0, 20.0, 8)
    assert times[0] == pytest.approx(0.2) and times[-1] == pytest.approx(20.0)
    assert 2.0 in times and len(times) == 9
    assert len(scoring.checkpoint_times(30.0, 20.0, 8)) == 8     # ours beyond a capped budget
    curve = [(1.0, 0.5), (3.0, 0.8)]
    assert [scoring.value_at(curve, t) for t in (0.5, 1.0, 2.9, 10)] == [0.0, 0.5, 0.5, 0.8]


def test_thinning_keeps_non_dominated_points_and_at_most_k():
    f = scoring.objectives([1.0, 1.1, 1.2, 1.3, 1.4, 1.35], [1.0, 1.5, 1.8, 1.9, 2.0, 1.0])
    assert sorted(scoring.thin(f, 10)) == [0, 1, 2, 3, 4]       # row 5 is dominated
    kept = scoring.thin(f, 3)
    assert len(kept) == 3 and 5 not in kept
    # the greedy drop of the least contributor keeps more than any pair of rows without it
    norm = scoring.Normalisation.of_fronts([f])
    assert norm.hypervolume(f[kept]) >= max(norm.hypervolume(f[[i, j]])
                                            for i in range(5) for j in range(i + 1, 5))


def test_an_optimum_beaten_on_its_own_epsilon_is_counted():
    def claim(status, kind, eps, delta, ratio, n=8):
        return {"status": status, "kind": kind, "epsilon": eps, "phases": n,
                "delta": delta, "ratio": ratio}
    end = claim("optimal", "largest_ratio", None, 0.105223, 0.689)
    claims = [claim("optimal", "least_ripple", 0.568, 0.1047, 0.568),
              claim("optimal", "sweep", 0.60, 0.105245, 0.601),     # the end reaches 0.60
              claim("local", "sweep", 0.61, 0.105400, 0.612),       # said to be local: fine
              claim("optimal", "sweep", 0.59, 0.1051, 0.59),        # nothing beats it
              claim("optimal", "sweep", 0.60, 0.2, 0.62, n=6),      # another count's problem
              end]
    assert scoring.beaten_optima(claims) == 1

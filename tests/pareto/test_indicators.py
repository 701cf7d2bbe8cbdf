"""Non-dominated filtering and the indicator maths on fronts whose answer is known by hand."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from optdesign.fronts.front import frame
from optdesign.fronts.indicators import (hypervolume_2d, indicators, knee, non_dominated,
                                         normalise, objectives, spacing)


def test_non_dominated_keeps_exactly_the_front():
    f = np.array([[1, 5], [2, 3], [3, 4], [4, 1], [2, 3], [5, 5], [1, 6]], float)
    # (3,4) is dominated by (2,3); (5,5) by everything; (1,6) by (1,5); the second (2,3) is
    # a duplicate: kept once
    assert non_dominated(f).tolist() == [True, True, False, True, False, False, False]


def test_objectives_minimise_ripple_and_maximise_ratio():
    f = objectives([0.1, 0.2, 0.3], [0.5, 0.9, 0.8])
    assert non_dominated(f).tolist() == [True, True, False]      # (0.3, 0.8) loses to (0.2, 0.9)


@settings(max_examples=50, deadline=None)
@given(st.lists(st.tuples(st.floats(0, 1), st.floats(0, 1)), min_size=1, max_size=30))
def test_no_kept_point_is_dominated_and_every_dropped_one_is(points):
    f = np.array(points)
    keep = non_dominated(f)
    for i in range(len(f)):
        dominated = any(np.all(f[j] <= f[i]) and np.any(f[j] < f[i]) for j in range(len(f)))
        if dominated:
            assert not keep[i]
        elif not keep[i]:
            assert any(np.all(f[j] == f[i]) for j in range(i))    # a duplicate of a kept one


def test_hypervolume_of_a_staircase_by_hand():
    """Points (0, 1), (0.5, 0.5), (1, 0), reference (1.1, 1.1): strips of width 0.5, 0.5, 0.1
    and height 0.1, 0.6, 1.1: 0.05 + 0.30 + 0.11 = 0.46 (exact up to rounding)."""
    z = np.array([[0.5, 0.5], [1, 0], [0, 1]])
    assert hypervolume_2d(z) == pytest.approx(0.46, abs=1e-12)
    # a dominated point and one beyond the reference change nothing
    assert hypervolume_2d(np.vstack([z, [[0.8, 0.8], [1.2, 0.0]]])) == pytest.approx(0.46,
                                                                                     abs=1e-12)
    assert hypervolume_2d(np.array([[0.0, 0.0]])) == pytest.approx(1.21, abs=1e-12)
    assert hypervolume_2d(np.zeros((0, 2))) == 0.0


def test_spacing_of_evenly_spaced_points_is_zero():
    t = np.linspace(0, 1, 7)
    assert spacing(np.column_stack([t, 1 - t])) == pytest.approx(0.0, abs=1e-12)
    assert spacing(np.array([[0, 1], [0.1, 0.9], [1, 0]])) > 0.1
    assert np.isnan(spacing(np.array([[0.0, 0.0]])))


def test_knee_of_a_bent_front():
    """On z2 = (1 - z1)^4 the farthest point from the chord z1 + z2 = 1 is near
    z1 = 1 - 4^(-1/3) = 0.370; the sample nearest to it is the knee."""
    t = np.linspace(0, 1, 101)
    z = np.column_stack([t, (1 - t) ** 4])
    assert t[knee(z)] == pytest.approx(1 - 4 ** (-1 / 3), abs=0.01)
    # a straight front has no bend: the point nearest the ideal
    assert knee(np.array([[0, 1], [0.5, 0.5], [1, 0]])) == 1


def test_normalisation_maps_ideal_and_nadir_to_the_unit_corners():
    f = objectives([0.1, 0.3], [0.5, 0.9])
    z, ideal, nadir = normalise(f)
    assert z.tolist() == [[0.0, 1.0], [1.0, 0.0]]
    ind = indicators([0.1, 0.3], [0.5, 0.9])
    assert ind["ideal"] == {"delta": 0.1, "ratio": 0.9}
    assert ind["nadir"] == {"delta": 0.3, "ratio": 0.5}
    # strips: (0, 1) is 1.0 wide and 0.1 high, (1, 0) is 0.1 wide and 1.1 high
    assert ind["hypervolume"] == pytest.approx(1.0 * 0.1 + 0.1 * 1.1, abs=1e-12)


def _rec(n, i, delta, ratio, status="optimal"):
    return {"key": [n, i], "count": n, "phases": n, "delta": delta, "ratio": ratio, "status": status,
            "design": {"l1": 1.0, "phases": n}}


def test_frame_flags_each_counts_front_and_the_overall_front():
    recs = [_rec(4, 0, 0.2, 0.8), _rec(4, 1, 0.3, 0.9), _rec(6, 0, 0.1, 0.7),
            _rec(6, 1, 0.25, 0.95), _rec(6, 2, None, None, "failed"),
            {"key": [6, "least_ripple"], "count": 6, "phases": 6}]
    df = frame(recs, ["l1"])
    assert len(df) == 5                                 # the raw end solve is not a row
    assert df["count_front"].tolist() == [True, True, True, True, False]
    # n = 4's (0.3, 0.9) loses to n = 6's (0.25, 0.95)
    assert df["non_dominated"].tolist() == [True, False, True, True, False]



def test_the_knee_on_the_values_own_scales_is_the_most_gain_per_ripple():
    """δ 0.1047 -> 0.1052 (0.5 %) while the ratio goes 0.568 -> 0.689 (21 %): the normalised
    chord would pick a bend of that 0.5 %; per unit of ripple the largest ratio wins. On a
    front where δ doubles for 2 % more ratio the least-δ end wins; for a quantity that is better
    small (a housing radius, sign −1) the least radius·δ."""
    from optdesign.fronts.indicators import value_knee

    ratio = np.array([0.568, 0.575, 0.6, 0.65, 0.689])
    delta = np.array([0.1047, 0.10476, 0.1049, 0.1051, 0.1052])
    assert value_knee(objectives(delta, ratio)) == 4
    assert indicators(delta, ratio)["knee_rule"] == "per_ripple"
    steep = np.array([0.1, 0.15, 0.2, 0.3, 0.4])
    assert value_knee(objectives(steep, np.linspace(0.80, 0.816, 5))) == 0
    radius = np.array([382.0, 250.0, 167.6, 130.0, 110.0])
    rip = np.array([0.0996, 0.13, 0.2039, 0.35, 0.5018])
    # radius·δ: 38.0, 32.5, 34.2, 45.5, 55.2
    assert value_knee(objectives(rip, -radius), sign=-1.0) == 1
    assert value_knee(objectives(delta, ratio - 0.6)) is None      # a ratio below zero


def test_a_design_whose_output_comes_to_rest_is_not_the_knee():
    """A slotted lever's front runs up to δ = 2 (ω_min = 0, the output at rest once a turn):
    past where δ stops growing the ratio per unit of ripple grows without limit, and the
    per-ripple rule took that design, the worst ripple there is. It is left out (counted);
    a front of such designs alone keeps its knee."""
    ratio = np.array([0.1, 0.5, 1.0, 1.5, 1.94, 2.44])
    delta = np.array([0.4, 0.9, 1.4, 1.8, 1.96, 2.0])
    assert indicators(delta, ratio)["knee"] == 5                  # the rule, unguarded
    guarded = indicators(delta, ratio, at_rest=2.0)
    assert guarded["knee"] == 4 and guarded["knee_rule"] == "per_ripple"
    assert guarded["knee_at_rest_excluded"] == 1
    assert indicators(np.array([2.0, 2.0]), np.array([1.0, 2.0]), at_rest=2.0)["knee"] == 1
    assert indicators(delta, ratio)["knee_at_rest_excluded"] == 0

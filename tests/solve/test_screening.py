"""Screening before IPOPT: basins by multi-level single linkage, the line screening beside an
optimum, and a real two-basin problem whose file start lies in the worse basin."""
from dataclasses import replace

import numpy as np
import pytest

from optdesign.problem.loader import Variable, load_problem
from optdesign.solver import solve
from optdesign.solver.phase_solver import PhaseSolver
from optdesign.solver.screening import Candidate, _basins, _crossings, screen
from tests.conftest import ROOT

DISC = ROOT / "problems" / "sharkov2022_disc.yaml"


def disc_problem(phases: int, min_ratio: float, **initial):
    p = load_problem(DISC)
    design = dict(p.design)
    design["phases"] = Variable("phases", value=float(phases))
    for k, v in initial.items():
        design[k] = replace(design[k], initial=v)
    return replace(p, design=design).with_limit("ratio", "lower", min_ratio or None)


def test_basins_keeps_one_seed_per_cluster():
    """Two clusters of designs in the unit box, each with its own best: two seeds, best first;
    the critical distance is MLSL's r_k (Rinnooy Kan & Timmer 1987)."""
    rng = np.random.default_rng(0)
    cands = []
    for centre, offset in (((0.2, 0.2), 0.0), ((0.8, 0.8), 1e-4)):
        for _ in range(40):
            u = np.clip(np.array(centre) + 0.03 * rng.standard_normal(2), 0, 1)
            cands.append(Candidate({}, offset + float(np.sum((u - centre) ** 2)), True, u))
    seeds, radius = _basins(cands, 2)
    assert len(seeds) == 2
    assert seeds[0].unit[0] < 0.5 < seeds[1].unit[0]       # one seed in each cluster
    assert radius == pytest.approx((1 * 2.0 * np.log(80) / 80) ** 0.5 / np.sqrt(np.pi))


def test_crossing_estimate_is_second_order():
    """Two straight curves crossing between samples: the screened trough is exact."""
    x = np.linspace(0, 1, 5)
    f = np.stack([1 - x, x])[:, None, :]                    # curves × 1 design × samples
    lows = _crossings(f)[0]
    assert np.nanmin(lows[np.isfinite(lows)]) == pytest.approx(0.5, abs=1e-15)


def test_crossings_take_the_next_sample_from_the_rolled_argmax_to_the_bit():
    """The next sample's driving curve and envelope are this sample's rolled by one, not a
    second argmax over the rolled curves: the same troughs to the bit, ties, NaN (a chain
    that does not assemble) and hand-overs at the turn's end included."""
    rng = np.random.default_rng(3)
    f = np.round(rng.normal(size=(5, 7, 40)), 1)            # rounded: many ties
    f[1, 2, 5:9] = np.nan
    nxt = np.roll(f, -1, axis=2)                             # the two argmaxes, as before
    a, b = f.argmax(axis=0), nxt.argmax(axis=0)
    pick = lambda g, c: np.take_along_axis(g, c[None], axis=0)[0]   # noqa: E731
    fa0, fa1, fb0, fb1 = pick(f, a), pick(nxt, a), pick(f, b), pick(nxt, b)
    gap0, gap1 = fa0 - fb0, fa1 - fb1
    with np.errstate(all="ignore"):
        t = np.clip(gap0 / np.where(gap0 != gap1, gap0 - gap1, 1.0), 0.0, 1.0)
        before = np.where(a != b, np.maximum(fa0 + t * (fa1 - fa0), 0.0), np.inf)
        now = _crossings(f)
        given = _crossings(f, a, fa0)        # the caller's argmax and envelope, as the screening
    assert np.array_equal(now, before, equal_nan=True)
    assert np.array_equal(given, before, equal_nan=True)
    assert np.isfinite(now).any() and np.isinf(now).any()


def test_screening_filters_and_counts():
    p = load_problem(DISC)
    s = screen(p, 6, 256)
    assert len(s.candidates) == 257                          # the file's design + 256 Sobol
    assert 0 < s.n_feasible < 257
    assert s.seeds and all(np.isfinite(c.score) for c in s.seeds)
    assert s.to_dict()["basins"] == len(s.seeds)


def test_the_screening_on_two_threads_ranks_the_same_designs_to_the_bit():
    """A solve that owns the cores screens on two threads (``lanes.threads``): every sampled
    score and violation is the one thread's to the bit, so the basins and seeds are too."""
    from optdesign.numerics import lanes

    p = disc_problem(24, 0.344)
    alone = screen(p, 24, 512)
    with lanes.threads(2):
        shared = screen(p, 24, 512)
    assert [(c.values, c.score, c.feasible) for c in alone.candidates] == \
        [(c.values, c.score, c.feasible) for c in shared.candidates]
    assert [c.values for c in alone.seeds] == [c.values for c in shared.seeds]


def _box_rows(p, count, n=512):
    """The screening's own rows of ``p`` at ``count``: (base, free, X)."""
    free = p.free_lengths()
    base = p.start_values() | {p.model.count_variable: count}
    s = screen(p, count, n)
    return base, free, np.array([[c.values[k] for k in free] for c in s.candidates])


@pytest.mark.parametrize("count, extra", [(24, {}), (6, {"eccentricities": (1.0, 0.5)})])
def test_rows_tried_for_assembly_first_score_as_one_pass_over_the_grid_to_the_bit(count, extra):
    """The rows that do not assemble at a few crank angles are dropped before the rest of the
    grid: every other row's score and violation, and each constraint's missed share, are one
    pass's over the whole grid to the bit; a dropped row's violation is inf (as the one pass
    gives), and most of the box's sample is dropped."""
    from optdesign.solver.screening import grid_samples, _assembling, _scores, sampled_scores

    p = replace(disc_problem(count, 0.344), **extra)
    base, free, X = _box_rows(p, count)
    missed: dict = {}
    score, violation = sampled_scores(p, count, base, free, X, missed=missed)
    lengths = {k: np.full(len(X), base[k], dtype=float) for k in p.model.lengths}
    lengths |= {k: X[:, j] for j, k in enumerate(free)}
    N = grid_samples(p, count)
    fmap = p.model.speeds_at_once(count, tuple(sorted(p.options.items())))
    one_missed: dict = {}
    one_score, one_violation = _scores(p, count, lengths, N, fmap, None, None, one_missed)
    keep, _ = _assembling(p, lengths, N, fmap)
    assert violation.tobytes() == one_violation.tobytes()
    assert score[keep].tobytes() == one_score[keep].tobytes()
    assert np.all(score[~keep] == np.inf) and np.all(one_violation[~keep] == np.inf)
    assert list(missed.items()) == list(one_missed.items())
    assert keep.sum() < len(X) / 2


def test_the_line_screening_scores_every_line_in_one_call_as_line_by_line(monkeypatch):
    """The lines through an optimum go through the speed function in one call (enough lanes
    for two threads): each line's scores and violations are those of a call of its own, to
    the bit."""
    from optdesign.solver import screening

    p = disc_problem(12, 0.344)
    result = solve(p)
    calls = []
    real = screening.sampled_scores

    def recorded(problem, count, base, free, X, *args, **kwargs):
        out = real(problem, count, base, free, X, *args, **kwargs)
        calls.append((base, free, X.copy(), out))
        return out

    monkeypatch.setattr(screening, "sampled_scores", recorded)
    screening.LineScreening(p, 12, result.design).seeds()
    assert len(calls) == 1
    base, free, X, (score, violation) = calls[0]
    lines, rest = divmod(len(X), screening.LINE_POINTS)
    assert lines >= 2 and not rest and np.any(violation <= 0)     # l0 and l2 on their bounds
    for at in range(lines):
        part = slice(at * screening.LINE_POINTS, (at + 1) * screening.LINE_POINTS)
        alone = real(p, 12, base, free, X[part])
        assert alone[0].tobytes() == score[part].tobytes()
        assert alone[1].tobytes() == violation[part].tobytes()


def test_a_box_where_nothing_assembles_misses_no_constraint():
    """No row assembles: every score and violation inf, each constraint's missed share 0
    under the names one pass gives."""
    from optdesign.solver.screening import grid_samples, _scores, sampled_scores

    p = disc_problem(6, 0.344)
    base = p.start_values() | {"phases": 6}
    free = p.free_lengths()
    X = np.full((4, len(free)), 1e-3)       # every link a thousandth of a millimetre
    X[:, free.index("l0")] = 1e4            # and the frame ten metres: nothing closes
    missed: dict = {}
    score, violation = sampled_scores(p, 6, base, free, X, missed=missed)
    assert np.all(score == np.inf) and np.all(violation == np.inf)
    lengths = {k: np.full(len(X), base[k], dtype=float) for k in p.model.lengths}
    lengths |= {k: X[:, j] for j, k in enumerate(free)}
    one: dict = {}
    fmap = p.model.speeds_at_once(6, tuple(sorted(p.options.items())))
    _scores(p, 6, lengths, grid_samples(p, 6), fmap, None, None, one)
    assert list(missed) == list(one) and all(v == 0.0 for v in missed.values())


def test_two_basins_file_start_in_the_worse_one():
    """The disc problem with 12 phases and ratio >= 0.2 has two basins: l3 ≈ 37.9 (angle slack,
    δ = 0.093852) and l3 ≈ 27.1 (transmission angle binding, δ = 0.092800). Started from the
    file's design in the worse basin, IPOPT alone returns the worse optimum; the solve returns
    the better one."""
    p = disc_problem(12, 0.2, l0=399.0, l2=399.0, l2_prime=274.0, l3=40.0)
    alone = PhaseSolver(p, 12).solve_from(p.start_values() | {"phases": 12})
    assert alone.record.feasible
    assert alone.verification.delta == pytest.approx(0.0938521418, abs=1e-8)
    r = solve(p)
    assert r.status == "optimal"
    assert r.delta == pytest.approx(0.0927998418, abs=1e-8)
    assert r.design["l3"] < 30
    assert r.min_transmission_angle_deg == pytest.approx(40.0, abs=0.05)
    assert r.per_phase[0].screening["distinct_optima"] >= 2


def test_nlp_is_built_once_per_phase_count():
    """Starts with other hand-over orders, a tightened angle and other ε reuse one NLP."""
    p = load_problem(DISC)
    solver = PhaseSolver(p, 6)
    starts = [p.start_values() | {"phases": 6},
              p.start_values() | {"phases": 6, "l0": 390.0, "l2": 390.0, "l2_prime": 260.0,
                                  "l3": 30.0}]
    outcomes = [solver.solve_from(v) for v in starts]
    outcomes.append(solver.solve_from(starts[1], min_ratio=0.5))
    assert all(o.record.feasible for o in outcomes)
    assert len(solver._nlps) == 1
    assert outcomes[2].verification.ratio >= 0.5 - 1e-7


def test_the_jacobian_needs_few_forward_directions_at_many_phases():
    """The mean as running sums: no constraint row reads every hand-over angle, so the
    constraint Jacobian's forward colouring stays small (9 at n = 24; 29 with one dense sum,
    which docs/solve.md's account of the speed-up quotes)."""
    import casadi as ca

    from optdesign.problem.loader import load_problem
    from optdesign.solver.nlp import PhaseNLP
    from tests.conftest import ROOT

    nlp = PhaseNLP(load_problem(ROOT / "problems" / "sharkov2022_disc.yaml"), 24)
    colours = ca.jacobian_sparsity(nlp.g, nlp.x_sym).uni_coloring().size2()
    assert colours <= 10


def test_bounds_of_six_decades_around_a_feasible_design_are_not_infeasible():
    """Every length bounded to [1e-3, 1e3] mm around the paper's disc problem, whose design is
    feasible: the screening finds the feasible region and the solve returns an optimum (once
    this said `infeasible`: no design within the bounds assembles)."""
    from dataclasses import replace

    from optdesign.problem.loader import load_problem
    from optdesign.solver.driver import solve_phase
    from tests.conftest import ROOT

    problem = load_problem(ROOT / "problems" / "sharkov2022_disc.yaml")
    wide = {k: replace(problem.design[k], lower=1e-3, upper=1e3)
            for k in problem.free_lengths()}
    result = solve_phase(replace(problem, design=problem.design | wide), 6)
    assert result.status == "optimal"
    assert result.delta < 0.1402049196            # the wider box holds a better design


def test_a_range_of_decades_is_screened_evenly_in_its_logarithm():
    """1e-3..1e3 mm: as many screened designs below 1 mm as above (evenly in mm, 99.9 % would
    lie above); a range of less than three decades stays even in mm."""
    import numpy as np
    from scipy.stats import qmc

    from optdesign.solver.screening import spread

    unit = qmc.Sobol(d=2, scramble=True, seed=0).random_base2(10)
    X = spread(unit, np.array([1e-3, 100.0]), np.array([1e3, 400.0]))
    below = np.mean(X[:, 0] < 1.0)
    assert 0.45 < below < 0.55
    assert np.all((X[:, 0] >= 1e-3) & (X[:, 0] <= 1e3))
    np.testing.assert_allclose(X[:, 1], 100.0 + 300.0 * unit[:, 1])


def test_the_lines_screened_one_at_a_time_give_the_seeds_of_one_call():
    """A line screening made a line at a time (as a wait for a polish beside makes it), a step
    past the last line included, gives the seeds of the lines screened in one call, to the
    bit."""
    from optdesign.solver import screening

    p = disc_problem(12, 0.344)
    design = solve(p).design
    stepped = screening.LineScreening(p, 12, design)
    lines = stepped.remaining
    assert lines >= 2
    for _ in range(lines + 1):
        stepped.step()
    assert stepped.remaining == 0
    whole = screening.LineScreening(p, 12, design).seeds()      # every line in one call
    assert [(c.values, c.score) for c in stepped.seeds()] == \
        [(c.values, c.score) for c in whole] and whole

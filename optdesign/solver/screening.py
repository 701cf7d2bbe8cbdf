"""Screening the box before IPOPT: thousands of designs on a coarse grid, clustered into basins.

A scrambled Sobol sample of the free lengths (and the file's own design) is evaluated at once
through the mechanism's speed function ``map``-ped over designs × crank samples: sampled δ,
ratio, the transmission angle and the mechanism's length constraints, every constraint a
filter. The designs that pass are clustered into basins by the multi-level single linkage rule
(Rinnooy Kan & Timmer, "Stochastic global optimization methods part II: multi level methods",
Math. Programming 39, 1987): a design seeds a basin when no better design lies within the
critical distance r_k of it, r_k = π^(-1/2)·(Γ(1 + d/2)·σ·log k / k)^(1/d) in the unit box.
The driver polishes the best basins with IPOPT.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from optdesign.envelope.sampled import STROKE_SIGNS, driving_speeds, ripple_of
from optdesign.evaluation.figures import eccentricities_of
from optdesign.numerics import sobol
from optdesign.quantities import get_quantity
from optdesign.quantities.criteria import (SectionConstraint, TransmissionAngle, constraints_of,
                                           objective_of, quantity_specs)
from optdesign.quantities.extremes import lanes_of

#: crank samples per turn of the screening grid: enough to rank designs (sampled δ is within
#: a few per cent of the exact δ), not to certify them; IPOPT and the exact check do that
SCREEN_SAMPLES = 48
#: and at least this many per rocker curve, so every hand-over is bracketed closely
SAMPLES_PER_CURVE = 8
#: slack of the screening's transmission-angle filter, degrees: the coarse grid misses the
#: worst angle by up to this much, and a design just outside may polish into the feasible set
ANGLE_SLACK_DEG = 2.0
#: σ of the critical distance (MLSL's theory asks σ > 4 for finitely many local searches; 2
#: splits basins more finely, and the driver polishes only the best few)
SIGMA = 2.0
#: share of the screened designs that may seed a basin (MLSL's reduced sample, γ)
REDUCED_SHARE = 0.25


@dataclass
class Candidate:
    """One screened design: its free lengths, its sampled score and whether it passed."""

    values: dict[str, float]
    score: float                 # rank: feasible by sampled objective, then by violation
    feasible: bool
    unit: np.ndarray             # position in the unit box of the free lengths
    #: the sampled objective's ranking key (inf where a filter fails): comparable, within the
    #: grid's error, with an exact verification's key
    objective: float = math.inf


@dataclass
class Screening:
    candidates: list[Candidate] = field(default_factory=list)     # every screened design
    seeds: list[Candidate] = field(default_factory=list)          # one per basin, best first
    radius: float = 0.0
    #: the seeds (the first) that each lead a polish to its end (the others beside them are
    #: polished with the secondary budget): two where a feasibility stage added designs to a
    #: box sample that passed a few (:func:`_led`)
    leads: int = 1
    n_feasible: int = 0
    #: the share of the box's assembling sample that breaks each constraint, by its name
    missed: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {"designs": len(self.candidates), "passed_filters": self.n_feasible,
                "basins": len(self.seeds), "critical_distance": self.radius}


@dataclass
class Scored:
    """The box's sample of one count scored on the screening's grid (the file's design and
    the Sobol designs, no other): each row's sampled objective key and largest violation,
    and the share of the assembling rows that break each constraint."""

    count: int
    X: np.ndarray
    score: np.ndarray
    violation: np.ndarray
    missed: dict
    seconds: float = 0.0        # the time it took

    @property
    def promise(self) -> float:
        """The best sampled objective key of any design that assembles, every other
        constraint aside (inf where none assembles): what the count's optimum may be
        expected to reach, the constraints only raising it (:func:`promise`)."""
        fine = np.isfinite(self.violation)
        return float(np.min(self.score[fine])) if fine.any() else math.inf


def _box(problem, count: int, n_designs: int, extra: list[dict] = ()):
    """(free, base, lower, upper, X): the rows a screening scores, the file's design first,
    then ``extra``, then ``n_designs`` Sobol designs of the box (:data:`WIDE_FACTOR` times as
    many in a box of decades)."""
    free = problem.free_lengths()
    base = problem.start_values() | {problem.model.count_variable: count}
    lower = np.array([problem.design[k].lower for k in free])
    upper = np.array([problem.design[k].upper for k in free])
    if np.any(wide(lower, upper)):
        n_designs *= WIDE_FACTOR
    rows = [np.array([d[k] for k in free]) for d in [base, *extra]]
    if free:
        rows += list(spread(sobol.unit_sample(len(free), n_designs, problem.solver.seed),
                            lower, upper))
    return free, base, lower, upper, np.array(rows).reshape(len(rows), len(free))


def _with_extra(problem, count: int, base: dict, free: list, scored: Scored,
                extra: np.ndarray) -> tuple[np.ndarray, np.ndarray, dict]:
    """(score, violation, missed) of the rows ``scored`` holds with the rows ``extra`` after
    its first (the file's design): only ``extra`` scored here. Each missed share is that of
    all the assembling rows (a share counts rows: it adds up exactly)."""
    if not len(extra):
        return scored.score, scored.violation, dict(scored.missed)
    missed: dict = {}
    score, violation = sampled_scores(problem, count, base, free, extra, None, missed)
    fine = [int(np.isfinite(v).sum()) for v in (scored.violation, violation)]
    merged = {name: (round(scored.missed[name] * fine[0]) + round(missed[name] * fine[1])) /
              sum(fine) if sum(fine) else 0.0 for name in scored.missed}
    return (np.concatenate([scored.score[:1], score, scored.score[1:]]),
            np.concatenate([scored.violation[:1], violation, scored.violation[1:]]), merged)


def promise(problem, count: int, n_designs: int) -> Scored:
    """The box's sample of ``count`` scored as :func:`screen` scores it without ``extra``
    designs (the same rows, the same values to the bit): its :attr:`Scored.promise` ranks
    the counts before any is polished, and :func:`screen` given it scores nothing again."""
    t0 = time.perf_counter()
    free, base, _, _, X = _box(problem, count, n_designs)
    missed: dict = {}
    score, violation = sampled_scores(problem, count, base, free, X, None, missed)
    return Scored(count, X, score, violation, missed, time.perf_counter() - t0)


def screen(problem, count: int, n_designs: int, extra: list[dict] = (),
           sampled: dict | None = None, scored: Scored | None = None) -> Screening:
    """Screen ``n_designs`` Sobol designs (:data:`WIDE_FACTOR` times as many in a box of
    decades) and the designs in ``extra``; seeds best first. ``sampled``, when given,
    receives the sampled ``delta`` and ``ratio`` of every candidate (arrays in the
    candidates' order: a Pareto sweep filters them by ratio >= ε). ``scored``: the same
    count's :func:`promise`, whose rows are these but ``extra``'s: they are not scored again
    (without ``sampled``; each row's figures are its own, so the same to the bit)."""
    free, base, lower, upper, X = _box(problem, count, n_designs, extra)
    box = np.delete(X, np.s_[1:1 + len(extra)], axis=0)     # the file's design, the sample
    if scored is not None and sampled is None and scored.count == count and \
            np.array_equal(scored.X, box):
        score, violation, missed = _with_extra(problem, count, base, free, scored,
                                               X[1:1 + len(extra)])
    else:
        missed = {}
        score, violation = sampled_scores(problem, count, base, free, X, sampled, missed)
    n_sample, passed = len(X), int(np.sum(violation <= 0))
    staged = bool(free) and sampled is None and too_few_pass(passed, lower, upper)
    if staged:
        X, score, violation = toward_feasible(problem, count, base, free, lower, upper,
                                              X, score, violation)
    feasible = violation <= 0
    unit = unit_of(X, lower, upper)
    out = Screening(n_feasible=int(feasible.sum()), missed=missed)
    # Feasible designs first, by their score; then the others, by how far they miss
    # (Deb's rules: a rank, so scores and violations never mix units).
    order = np.lexsort((np.where(feasible, score, violation), ~feasible))
    key = np.empty(len(X))
    key[order] = np.arange(len(X), dtype=float)
    key[~np.isfinite(violation)] = np.inf     # does not assemble: never a seed
    for i in range(len(X)):
        out.candidates.append(Candidate(base | dict(zip(free, X[i])), float(key[i]),
                                        bool(feasible[i]), unit[i],
                                        float(score[i]) if feasible[i] else math.inf))
    if staged and passed:
        out.seeds, out.radius, out.leads = _led(out.candidates, n_sample, len(free))
    else:
        out.seeds, out.radius = _basins(out.candidates, len(free))
    return out


def _led(candidates: list[Candidate], n_sample: int, d: int) -> tuple[list, float, int]:
    """The seeds of a screening whose box sample (its first ``n_sample`` candidates) passed
    the filters too few times and whose feasibility stage added the rest: each part's own
    basins (MLSL counts on an even sample: the stage's designs, drawn around the least
    violating ones, lie beside every passing design of the sample and would join every basin
    into one), the best of each first, then the others best first; and how many lead (the
    sample's best, and the stage's where it passes: each polished to its end, since in a box
    of decades a basin's path to its optimum can take hundreds of iterations). Returns the
    seeds, the sample's critical distance and the leads."""
    sample, radius = _basins(candidates[:n_sample], d)
    stage, _ = _basins(candidates[n_sample:], d)
    leads = [sample[0]] + [c for c in stage[:1] if c.feasible]
    rest = [c for c in sample + stage if not any(c is lead for lead in leads)]
    return (sorted(leads, key=lambda c: c.score) + sorted(rest, key=lambda c: c.score),
            radius, len(leads))


#: a free length whose range spans at least this ratio (two decades) is sampled evenly in
#: its logarithm, and the basins' distances are measured there: evenly in mm, nearly every
#: design of a 1e-3..1e3 mm range would lie above 1 mm, the basins at small lengths would go
#: unseen, and every design of a linkage's size would fall within one critical distance
LOG_SPAN = 1e2
#: a box with a range of :data:`LOG_SPAN` or more is screened with this many times
#: ``solver.screen`` designs: a basin of a linkage's proportions fills a share of the box that
#: shrinks with every decade of its ranges (on the four-bar in boxes of three to five decades,
#: 512 designs led IPOPT to optima a 4096-design sample of the box beat, and 4096 to optima far
#: below it)
WIDE_FACTOR = 8


#: a box with a range of :data:`LOG_SPAN` or more gives each IPOPT run this many times
#: ``solver.max_iter`` iterations: the path from a screened seed to its optimum crosses
#: decades (on the four-bar in boxes of two to five decades, 14 of 96 counts ended with no
#: polish converged in 100 iterations, where 300 reach optima up to half their ripple)
WIDE_ITERATIONS = 3


def of_decades(problem) -> bool:
    """Whether a free length's range spans :data:`LOG_SPAN` or more (a box of decades)."""
    free = problem.free_lengths()
    lower = np.array([problem.design[k].lower for k in free])
    upper = np.array([problem.design[k].upper for k in free])
    return bool(free) and bool(np.any(wide(lower, upper)))


def iterations_of(problem) -> int:
    """IPOPT's iterations per run: ``solver.max_iter``, :data:`WIDE_ITERATIONS` times as
    many in a box of decades."""
    return (WIDE_ITERATIONS if of_decades(problem) else 1) * problem.solver.max_iter


def wide(lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """Which ranges span :data:`LOG_SPAN` or more (sampled in their logarithm)."""
    return upper >= LOG_SPAN * lower


def unit_of(X: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """Designs' positions in the unit box of the free lengths: the inverse of
    :func:`spread` (logarithmic on a range of :data:`LOG_SPAN` or more)."""
    span = np.where(upper > lower, upper - lower, 1.0)
    out = (X - lower) / span
    logarithmic = wide(lower, upper)
    if np.any(logarithmic):
        lo, hi = lower[logarithmic], upper[logarithmic]
        out[:, logarithmic] = np.log(X[:, logarithmic] / lo) / np.log(hi / lo)
    return out


def spread(unit: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """Points of the unit cube spread over the box: evenly where a range spans less than
    :data:`LOG_SPAN`, evenly in the logarithm where it spans more (the NLP's own scaling,
    by the geometric mean of the bounds, is logarithmic too)."""
    out = sobol.scale(unit, lower, upper) if len(unit) else unit.reshape(0, len(lower))
    logarithmic = wide(lower, upper)
    if np.any(logarithmic) and len(unit):
        lo, hi = lower[logarithmic], upper[logarithmic]
        out[:, logarithmic] = lo * (hi / lo) ** unit[:, logarithmic]
    return out


#: the feasibility stage: rounds of designs sampled around the least violating ones so far
FEASIBILITY_ROUNDS = 24
FEASIBILITY_BATCH = 256
#: designs a round samples around, and the feasible designs that end the stage early
ELITES = 16
ENOUGH_FEASIBLE = 16
#: the stage stops early where the least violation has stalled: where :data:`STALL_ROUNDS`
#: rounds lowered it by less than :data:`STALL_GAIN` of itself (a bound beyond the reach of
#: the box, which the relaxed solve then tells, not a search's slow progress)
STALL_ROUNDS = 3
STALL_GAIN = 0.01
#: least spread of a round's samples around an elite, in the lengths' logarithm (3 %)
LEAST_SPREAD = 0.03
#: the lengths relative to the regulated one (the crank) that the stage's first round tries:
#: a linkage's figures depend on the ratios of its lengths alone (δ and the ratio are
#: scale-free), and its links are seldom shorter than half the crank or longer than 40 times it
RELATIVE = (0.5, 40.0)


def too_few_pass(passed: int, lower: np.ndarray, upper: np.ndarray) -> bool:
    """Whether a screening's sample, ``passed`` of whose designs pass the filters, calls for
    the feasibility stage (:func:`toward_feasible`): where none of it passes the filters, or,
    in a box of decades (:data:`LOG_SPAN`), where fewer than :data:`ENOUGH_FEASIBLE` pass. A
    linkage's feasible proportions fill a share of such a box that shrinks with every decade,
    and its few passing designs may all lie far from the basins: a four-bar's ripple maximised at 8 phases in a box of 4.35 decades passed
    8 of 4097 designs, whose polishes ran out of iterations and left δ 0.62, where a design
    of a box sample polishes to 0.9994 (``benchmarks/solve_oracle.py --counts``). In a
    narrower box few passing designs are the constraints' own word (the disc problem passes 3
    of 513 and its polishes find its optimum), and the stage would only add polishes. Where
    the stage runs on a sample that passed a few, its basins and the sample's are counted
    apart (:func:`_led`)."""
    return passed == 0 or (passed < ENOUGH_FEASIBLE and bool(np.any(wide(lower, upper))))


def toward_feasible(problem, count: int, base: dict, free: list, lower, upper, X, score,
                    violation):
    """The screened designs with a feasibility stage's added to them, where too few of the
    box's sample pass the filters (:func:`too_few_pass`: a box decades wider than the
    linkage, or a narrow feasible set): a first round of lengths relative to the regulated one
    (:data:`RELATIVE`), then rounds sampled log-normally around the :data:`ELITES` least
    violating designs so far, their spread the elites' own, until :data:`ENOUGH_FEASIBLE`
    designs pass (the constraint violation is lowered before the objective is looked at;
    feasible designs rank first, by their score, Deb's rules), or until the least violation
    stalls (:data:`STALL_ROUNDS`). Deterministic: seeded by ``solver.seed``."""
    rng = np.random.default_rng(problem.solver.seed)
    batch = _relative_to_regulated(problem, base, free, lower, upper, rng)
    Xs, scores, violations = [X], [score], [violation]
    least: list[float] = []         # the least violation after each round
    log_lo, log_hi = np.log(lower), np.log(upper)
    for _ in range(FEASIBILITY_ROUNDS + 1):
        if batch is not None:
            s, v = sampled_scores(problem, count, base, free, batch)
            Xs.append(batch)
            scores.append(s)
            violations.append(v)
        every, v = np.vstack(Xs), np.concatenate(violations)
        if np.sum(v <= 0) >= ENOUGH_FEASIBLE:
            break
        least.append(float(np.min(v)))
        if len(least) > STALL_ROUNDS and 0 < least[-1] and \
                least[-1] > (1.0 - STALL_GAIN) * least[-1 - STALL_ROUNDS]:
            break
        ranked = np.lexsort((np.where(v <= 0, np.concatenate(scores), v), ~(v <= 0)))
        elites = np.log(every[ranked[:ELITES]][np.isfinite(v[ranked[:ELITES]])])
        if not len(elites):          # nothing assembles yet: the box again, in its logarithm
            batch = np.exp(rng.uniform(log_lo, log_hi, (FEASIBILITY_BATCH, len(free))))
            continue
        spread_ = np.maximum(elites.std(axis=0), LEAST_SPREAD)
        centres = elites[rng.integers(len(elites), size=FEASIBILITY_BATCH)]
        z = centres + rng.normal(0.0, 1.0, centres.shape) * spread_
        batch = np.exp(np.clip(z, log_lo, log_hi))
    return np.vstack(Xs), np.concatenate(scores), np.concatenate(violations)


def _relative_to_regulated(problem, base: dict, free: list, lower, upper, rng):
    """:data:`FEASIBILITY_BATCH` designs whose free lengths are log-uniform multiples of
    the regulated length within :data:`RELATIVE` (and the box); the regulated length itself
    log-uniform in its bounds where it is free. None where the mechanism regulates no length
    among its lengths."""
    regulated = problem.model.regulating_variable
    if regulated not in base:
        return None
    n = FEASIBILITY_BATCH
    if regulated in free:
        j = free.index(regulated)
        scale = np.exp(rng.uniform(np.log(lower[j]), np.log(upper[j]), n))
    else:
        scale = np.full(n, float(base[regulated]))
    out = np.empty((n, len(free)))
    for j, name in enumerate(free):
        if name == regulated:
            out[:, j] = scale
            continue
        lo = np.maximum(lower[j], RELATIVE[0] * scale)
        hi = np.minimum(upper[j], RELATIVE[1] * scale)
        lo, hi = np.where(lo < hi, lo, lower[j]), np.where(lo < hi, hi, upper[j])
        out[:, j] = np.exp(rng.uniform(np.log(lo), np.log(hi)))
    return out


def sampled_scores(problem, count, base, free, X, sampled: dict | None = None,
                   missed: dict | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(score, violation) of every design row of X: sampled objective, and the largest
    constraint violation (<= 0 when every filter passes; inf when it does not assemble);
    ``sampled`` (if given) receives the sampled worst δ and ratio of each row, ``missed`` the
    share of the assembling rows that break each constraint, by its name.

    Without ``sampled``, the rows are first tried on every :data:`ASSEMBLY_STRIDE`-th of the
    grid's crank angles at e = 1 (:func:`_assembling`): a row that does not assemble there
    does not assemble on the grid (violation inf, score inf) and is not evaluated further;
    the others are evaluated on the rest of the grid. Each row is computed on its own, so every row's
    figures are the same to the bit as from one pass over the whole grid (two thirds of a
    box's sample of the four-bar do not assemble: at 24 phases the screening's speed
    function is evaluated at 40 % of the lanes)."""
    model = problem.model
    S = X.shape[0]
    N = grid_samples(problem, count)
    fmap = model.speeds_at_once(count, tuple(sorted(problem.options.items())))
    lengths = {k: np.full(S, base[k], dtype=float) for k in model.lengths}
    for j, k in enumerate(free):
        lengths[k] = X[:, j]
    if sampled is not None or S == 0 or N % ASSEMBLY_STRIDE:
        return _scores(problem, count, lengths, N, fmap, None, sampled, missed)
    keep, first = _assembling(problem, lengths, N, fmap)
    score, violation = np.full(S, np.inf), np.full(S, np.inf)
    if keep.any():
        kept = {k: v[keep] for k, v in lengths.items()}
        score[keep], violation[keep] = _scores(problem, count, kept, N, fmap, first, None,
                                               missed)
    elif missed is not None:        # no row assembles: no share breaks a constraint (named in
        # _scores' order: the other constraints, then the transmission angles)
        named = [c for c in constraints_of(problem) if not isinstance(c, SectionConstraint)]
        missed.update({c.name: 0.0
                       for c in sorted(named, key=lambda c: isinstance(c, TransmissionAngle))})
    return score, violation


#: relative margin under which a sampled floor of δ is not taken to beat a verified δ: the
#: screening's speed function and the exact evaluator's are the same arithmetic written apart,
#: a few roundings from each other
FLOOR_MARGIN = 1e-9


def ripple_floor(problem, count: int, values: dict) -> float:
    """A floor under the exact worst midrange δ of the design ``values`` over the listed
    eccentricities: at each, the largest and the least value of the output's envelope (the
    fastest rocker, or rest) on the screening's grid of crank angles are values the exact
    envelope takes, so the exact ω_max is at least the one and the exact ω_min at most the
    other, and δ = 2(ω_max − ω_min)/(ω_max + ω_min) grows with ω_max and falls with ω_min
    (Sharkov & Kalinin 2022, the formula after eq. 8). No hand-over is interpolated (that
    estimate may fall below the exact trough). NaN where the design does not assemble on the
    grid, or for the time-mean ripple (no such floor: the sampled mean bounds nothing)."""
    if problem.objective.ripple != "midrange":
        return math.nan
    model = problem.model
    N = grid_samples(problem, count)
    fmap = model.speeds_at_once(count, tuple(sorted(problem.options.items())))
    lengths = {k: np.array([float(values[k])]) for k in model.lengths}
    phi = np.linspace(0.0, 2 * np.pi, N, endpoint=False)[None, :]
    floor = -math.inf
    with np.errstate(all="ignore"):
        for e in problem.eccentricities:
            dth, _ = fmap(phi, np.repeat(parameter_rows(model, lengths, e), N, axis=1))
            envelope = np.maximum(driving_speeds(dth, problem.stroke).max(axis=0), 0.0)
            if not np.all(np.isfinite(envelope)):
                return math.nan
            floor = max(floor, float(ripple_of(envelope.max(), envelope.min(), None)))
    return floor if math.isfinite(floor) else math.nan


def parameter_rows(model, lengths: dict, e: float) -> np.ndarray:
    """The mechanism's lengths (arrays over the designs) as its functions' parameter rows at
    eccentricity ``e``: the regulated length scaled by ``e``, the others as they are."""
    return np.vstack([lengths[k] * (e if k == model.regulating_variable else 1.0)
                      for k in model.lengths])


def grid_samples(problem, count: int) -> int:
    """Crank samples per turn of the screening's grid: :data:`SAMPLES_PER_CURVE` per rocker
    curve of the stroke, at least :data:`SCREEN_SAMPLES`."""
    return max(SCREEN_SAMPLES, SAMPLES_PER_CURVE * count * len(STROKE_SIGNS[problem.stroke]))


#: every this many crank angles of the screening's grid (one per rocker curve where the grid
#: has :data:`SAMPLES_PER_CURVE` per curve), each row is tried for assembly before the rest
#: of the grid: of the four-bar's box samples that do not assemble (two thirds), they find
#: 347 of 348 at 24 phases, 341 of 345 at four
ASSEMBLY_STRIDE = 8


def _assembling(problem, lengths: dict, N: int, fmap):
    """Which rows of ``lengths`` may assemble: none of the speed function's values is
    non-finite and no |cos μ| exceeds 1 at every :data:`ASSEMBLY_STRIDE`-th angle of the
    ``N`` of the grid, at e = 1 (the first of :func:`eccentricities_of`); and, for the rows
    that may, the speed function's values on the whole grid at e = 1 (those angles' values
    kept, the others evaluated): ``(keep, (dtheta, cos_mu))``, arrays of curves × (kept rows
    · N samples), as one pass over the grid lays them out."""
    S = len(next(iter(lengths.values())))
    m = ASSEMBLY_STRIDE
    grid = np.linspace(0.0, 2 * np.pi, N, endpoint=False).reshape(N // m, m)
    P = parameter_rows(problem.model, lengths, eccentricities_of(problem)[0])
    with np.errstate(all="ignore"):
        tried = [np.asarray(a).reshape(-1, S, N // m) for a in
                 fmap(np.tile(grid[:, 0], S)[None, :], np.repeat(P, N // m, axis=1))]
        dth, cos_mu = tried
        worst = np.maximum(cos_mu.max(axis=(0, 2)), -cos_mu.min(axis=(0, 2)))
        keep = np.isfinite(worst) & (worst <= 1.0) & np.all(np.isfinite(dth), axis=(0, 2))
        K = int(keep.sum())
        if not K:
            return keep, None
        rest = fmap(np.tile(grid[:, 1:].ravel(), K)[None, :],
                    np.repeat(P[:, keep], N - N // m, axis=1))
        first = []
        for at_tried, at_rest in zip(tried, rest):
            whole = np.empty((at_tried.shape[0], K, N // m, m))
            whole[..., 0] = at_tried[:, keep]
            whole[..., 1:] = np.asarray(at_rest).reshape(-1, K, N // m, m - 1)
            first.append(whole.reshape(-1, K * N))
    return keep, first


def _scores(problem, count, lengths: dict, N: int, fmap, first, sampled, missed):
    """:func:`sampled_scores` of the rows of ``lengths`` on the grid of ``N`` crank angles;
    ``first``: the speed function's values at e = 1 where :func:`_assembling` has them."""
    model = problem.model
    S = len(next(iter(lengths.values())))
    phi = np.tile(np.linspace(0.0, 2 * np.pi, N, endpoint=False), S)[None, :]
    c = problem.constraints
    cos_limit = min(math.cos(math.radians(max(c.min_transmission_angle_deg -
                                              ANGLE_SLACK_DEG, 0.0))),
                    math.sqrt(1.0 - c.assembly_margin))
    violation = np.full(S, -np.inf)
    angle_missed = np.full(S, -np.inf)
    ripples, ratio, envelope = [], None, {}
    with np.errstate(all="ignore"):
        for e in eccentricities_of(problem):
            P = parameter_rows(model, lengths, e)
            if e == 1.0 and first is not None:
                dth, cos_mu = first
            else:
                dth, cos_mu = fmap(phi, np.repeat(P, N, axis=1))  # fresh arrays: no copy
            n = dth.shape[0]
            # read in place: a copy of these arrays, in fresh memory, costs more than the
            # arithmetic on them (x / 1 is x to the bit)
            f = driving_speeds(dth, problem.stroke).reshape(-1, S, N)
            if e != 1.0:
                f = f / e
            driving = f.argmax(axis=0)
            top = _pick(f, driving)         # the envelope before the output at rest
            env = np.maximum(top, 0.0)
            hi, mean = env.max(axis=1), env.mean(axis=1)
            lo = np.minimum(env.min(axis=1), _crossings(f, driving, top).min(axis=1))
            delta = ripple_of(hi, lo, mean, problem.objective.ripple)
            if e in problem.eccentricities:
                ripples.append(delta)
            if e == 1.0:
                ratio, peak = mean, hi
            cos_mu = cos_mu.reshape(n, S, N)         # max |cos μ| without a copy of |cos μ|
            worst_cos = np.maximum(cos_mu.max(axis=(0, 2)), -cos_mu.min(axis=(0, 2)))
            envelope[e] = {"ratio": mean * e, "ripple": delta,
                           "peak_speed": hi * e * problem.input_speed,
                           "transmission_angle":
                               np.degrees(np.arccos(np.clip(worst_cos, 0.0, 1.0)))}
            bad = ~np.isfinite(worst_cos) | ~np.all(np.isfinite(f), axis=(0, 2)) | \
                (worst_cos > 1.0)
            violation = np.maximum(violation, np.where(bad, np.inf, worst_cos - cos_limit))
            angle_missed = np.maximum(angle_missed, worst_cos - cos_limit)
        q = _Sampled(lengths, ratio, np.max(ripples, axis=0), peak * problem.input_speed,
                     sampled_quantities(problem, count, lengths, envelope))
        for criterion in constraints_of(problem):
            if isinstance(criterion, (TransmissionAngle, SectionConstraint)):
                continue        # the angle is filtered above, with slack; sections at the check
            lower, upper = criterion.bounds(problem)
            v = np.asarray(criterion.value(q), dtype=float)
            scale = max([1.0] + [abs(b) for b in (lower, upper) if math.isfinite(b)])
            broken = np.maximum(lower - v, v - upper) / scale
            violation = np.maximum(violation, broken)
            if missed is not None:
                missed[criterion.name] = broken
        if missed is not None:
            missed.update({c.name: angle_missed for c in constraints_of(problem)
                           if isinstance(c, TransmissionAngle)})
            fine = np.isfinite(violation)
            for name, broken in list(missed.items()):
                broken = np.broadcast_to(np.asarray(broken, float), violation.shape)
                missed[name] = float(np.mean(broken[fine] > 0)) if fine.any() else 0.0
        score = objective_of(problem).key(q)
        if sampled is not None:
            sampled.update(delta=np.asarray(q.worst_ripple, float),
                           ratio=np.asarray(q.ratio, float), quantities=q.quantities)
    violation = np.where(np.isnan(violation), np.inf, violation)
    score = np.where(np.isfinite(score), score, np.inf)
    return score, violation


def _pick(f: np.ndarray, curve: np.ndarray) -> np.ndarray:
    """``f[curve[s, i], s, i]``: each sample's value of the curve ``curve`` names."""
    return np.take_along_axis(f, curve[None], axis=0)[0]


def _crossings(f: np.ndarray, driving: np.ndarray | None = None,
               top: np.ndarray | None = None) -> np.ndarray:
    """Envelope value where the driving curve changes between two samples, each curve taken
    linear in between: the kink (the trough) that the samples step over, to O(h²).

    ``f``: curves × designs × samples; ``driving``, ``top``: its argmax and max over the
    curves, where the caller has them. Returns designs × samples (inf where no hand-over).
    The next sample's values are picked from ``f`` where they lie, not from a rolled copy
    of ``f`` (the same values, without writing curves × designs × samples anew).
    """
    a = f.argmax(axis=0) if driving is None else driving
    b = np.roll(a, -1, axis=1)          # the next sample's driving curve
    fa0 = _pick(f, a) if top is None else top
    fa1 = np.roll(_pick(f, np.roll(a, 1, axis=1)), -1, axis=1)   # curve a[i] at sample i + 1
    fb0 = _pick(f, b)
    fb1 = np.roll(fa0, -1, axis=1)      # the next sample's envelope: curve b[i] at i + 1
    gap0, gap1 = fa0 - fb0, fa1 - fb1
    t = np.clip(gap0 / np.where(gap0 != gap1, gap0 - gap1, 1.0), 0.0, 1.0)
    value = np.maximum(fa0 + t * (fa1 - fa0), 0.0)
    return np.where(a != b, value, np.inf)


@dataclass
class _Sampled:
    """The NLP's named quantities, as arrays over the screened designs (sampled)."""

    lengths: dict
    ratio: np.ndarray
    worst_ripple: np.ndarray
    peak_speed: np.ndarray
    quantities: dict = field(default_factory=dict)


@dataclass
class SampledView:
    """What the screening sampled of its designs, for the quantities' sampled forms
    (:meth:`~optdesign.quantities.base.Quantity.sampled_value`): the envelope's figures per
    eccentricity (``ratio``, ``ripple``, ``peak_speed``, ``transmission_angle``, arrays over
    the designs) and a turn quantity's per-angle function sampled on the same grid."""

    problem: object
    count: int
    lengths: dict
    envelope: dict
    input_speed: float

    def turn(self, quantity, eccentricity: float) -> np.ndarray:
        """g of a turn quantity at (components, designs, angles), on :data:`SAMPLES_PER_CURVE`
        crank angles per chain (at least :data:`SCREEN_SAMPLES`): the screening's own grid for
        a stroke of one sign, half of it for both strokes (a turn quantity's value is its
        largest over the turn, read on this grid alone)."""
        model = self.problem.model
        options = tuple(sorted(self.problem.options.items()))
        g, _ = quantity.function(model, self.count, options)
        S = len(next(iter(self.lengths.values())))
        N = max(SCREEN_SAMPLES, SAMPLES_PER_CURVE * self.count)
        phi = np.tile(np.linspace(0.0, 2 * np.pi, N, endpoint=False), S)[None, :]
        P = parameter_rows(model, self.lengths, eccentricity)
        grid = _sample_lanes(g, phi, np.repeat(P, N, axis=1))
        return grid.reshape(grid.shape[0], S, N)


def sampled_quantities(problem, count: int, lengths: dict, envelope: dict) -> dict:
    """Each quantity spec's sampled value per screened design (its sampled form, at its
    eccentricity or the worst over the listed ones). ``envelope``: the sampled envelope's
    figures by eccentricity (:class:`SampledView`)."""
    view = SampledView(problem, count, lengths, envelope, problem.input_speed)
    out = {}
    for spec in quantity_specs(problem):
        quantity = get_quantity(spec.name)
        e = spec.at if spec.at is not None else quantity.at
        values = [quantity.sampled_value(view, x)
                  for x in ([e] if e is not None else problem.eccentricities)]
        out[spec.key] = np.max(values, axis=0) if quantity.worst == "max" else \
            np.min(values, axis=0)
    return out


def _sample_lanes(function, phi, P) -> np.ndarray:
    """``function`` at many (φ, p) columns: NumPy lanes, or CasADi's ``map``."""
    lanes = lanes_of(function)
    if lanes is not None:
        return lanes(phi, P)[0]
    return np.array(function.map(P.shape[1])(phi, P))


def _basins(candidates: list[Candidate], d: int) -> tuple[list[Candidate], float]:
    """MLSL seeds: in the reduced sample (the best share), a design no better design lies
    within the critical distance of. Returns the seeds, best first, and the distance."""
    order = sorted(range(len(candidates)), key=lambda i: candidates[i].score)
    order = [i for i in order if math.isfinite(candidates[i].score)]
    if not order:
        return [], 0.0
    k = len(candidates)
    if d == 0:
        return [candidates[order[0]]], 0.0
    radius = (math.gamma(1 + d / 2) * SIGMA * math.log(k) / k) ** (1 / d) / math.sqrt(math.pi)
    reduced = order[:max(1, int(math.ceil(REDUCED_SHARE * len(order))))]
    seeds = []
    points = np.array([candidates[i].unit for i in reduced])
    for rank, i in enumerate(reduced):
        if rank == 0 or np.min(np.linalg.norm(points[:rank] - points[rank], axis=1)) > radius:
            seeds.append(candidates[i])
    return seeds, radius


#: designs per line of the line screening
LINE_POINTS = 64


class LineScreening:
    """The box screened again on lines through an optimum ``values``, one per free length
    inside its bounds (the others held, so the bounds the optimum rests on stay active; evenly
    spaced as the box's sample is, in the logarithm of a range of decades): the local minima
    of the sampled objective along each line, among the designs that pass the filters and
    away from the optimum itself, best first (:meth:`seeds`). A narrow basin next to the
    optimum's face, which a sample of the whole box steps over, is found this way.

    Each design is evaluated on its own, so the lines may be screened one at a time
    (:meth:`step`, where a core waits for a polish beside) and the rest at once: the seeds are
    the same to the bit."""

    def __init__(self, problem, count: int, values: dict):
        self.problem, self.count = problem, count
        self.through = tuple(sorted(values.items()))    # the design the lines pass through
        self.free = problem.free_lengths()
        self.base = problem.start_values() | {problem.model.count_variable: count}
        self.centre = np.array([values[k] for k in self.free], dtype=float)
        self.lower = np.array([problem.design[k].lower for k in self.free])
        self.upper = np.array([problem.design[k].upper for k in self.free])
        span = self.upper - self.lower
        self.lines = [j for j in range(len(self.free))
                      if min(self.centre[j] - self.lower[j],
                             self.upper[j] - self.centre[j]) > 1e-6 * span[j]]
        line = np.linspace(0.0, 1.0, LINE_POINTS)
        self.rows = np.tile(self.centre, (LINE_POINTS * len(self.lines), 1))
        for at, j in enumerate(self.lines):
            self.rows[at * LINE_POINTS:(at + 1) * LINE_POINTS, j] = \
                spread(line[:, None], self.lower[j:j + 1], self.upper[j:j + 1])[:, 0]
        self.scores = np.empty(len(self.rows))
        self.violations = np.empty(len(self.rows))
        self.screened = 0           # rows screened so far, line by line
        self._seeds: list[Candidate] | None = None

    def passes_through(self, values: dict) -> bool:
        """Whether these lines pass through the design ``values``."""
        return self.through == tuple(sorted(values.items()))

    @property
    def remaining(self) -> int:
        """Lines not screened yet."""
        return (len(self.rows) - self.screened) // LINE_POINTS

    def step(self) -> None:
        """Screen the next line (none once every line is)."""
        self._screen(min(self.screened + LINE_POINTS, len(self.rows)))

    def _screen(self, end: int) -> None:
        """Screen the rows up to ``end`` not screened yet, in one call (its lanes shared
        between threads where the caller owns the cores)."""
        if end > self.screened:
            part = slice(self.screened, end)
            self.scores[part], self.violations[part] = sampled_scores(
                self.problem, self.count, self.base, self.free, self.rows[part])
            self.screened = end

    def seeds(self) -> list[Candidate]:
        """The local minima of every line, best first (the lines not screened yet screened
        first, in one call)."""
        if self._seeds is not None:
            return self._seeds
        self._screen(len(self.rows))
        out = []
        step = 1.0 / (LINE_POINTS - 1)
        for at, j in enumerate(self.lines):
            part = slice(at * LINE_POINTS, (at + 1) * LINE_POINTS)
            X, ok = self.rows[part], self.violations[part] <= 0
            s = np.where(ok, self.scores[part], np.inf)
            unit = unit_of(X, self.lower, self.upper)
            here = unit_of(self.centre[None, :], self.lower, self.upper)[0, j]
            for i in range(LINE_POINTS):
                left = s[i - 1] if i > 0 else np.inf
                right = s[i + 1] if i < LINE_POINTS - 1 else np.inf
                if ok[i] and s[i] <= left and s[i] <= right and \
                        abs(unit[i, j] - here) > 2 * step:
                    out.append(Candidate(self.base | dict(zip(self.free, X[i])), float(s[i]),
                                         True, unit[i], float(s[i])))
        self._seeds = sorted(out, key=lambda c: c.score)
        return self._seeds

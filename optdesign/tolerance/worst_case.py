"""The worst part in the tolerance box, found by optimisation and measured exactly.

The box is ± the tolerance of every length, whatever the Monte Carlo's distribution. The
worst point of a smooth δ over a small box is usually a corner, but not always (δ is a
maximum over eccentricities and a minimum over hand-overs, and curves inside the box), so:

1. starts: every corner (a sample of 256 when there are more than 2⁸), the corner the
   gradient at the nominal points to, and the worst parts of a Monte Carlo sample (the
   caller's, or 4096 uniform parts), all ranked on the vectorised evaluator;
2. from the best few distinct starts, a bounded local maximisation (L-BFGS-B) on the
   vectorised evaluator (central differences, all in one call), each end point then
   measured on the exact evaluator;
3. from the best end point, the same maximisation on the exact evaluator (its gradient by
   forward differences of exact figures), then a compass search (steps of half, a tenth and
   a fiftieth of the box), which a kink between two smooth pieces cannot stall.

Every figure compared and reported is the exact evaluator's; a part that does not assemble
ends the search (δ is then infinite, the least transmission angle 0).

The worst part for a bound on another quantity (a robust solve's housing radius, by the
bound's key) has no vectorised form: its starts are the box's corners measured exactly (all of
them up to 2⁵, else the gradient's corner and a sample), then stages 3's searches.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from optdesign.quantities import get_quantity
from optdesign.tolerance.exact_part import exact_part
from optdesign.tolerance.montecarlo import evaluate_offsets
from optdesign.tolerance.parts import Box, box_of

QUANTITIES = ("ripple", "transmission_angle")
#: corners measured exactly as starts of a bound's worst part (all of them up to 2⁵)
EXACT_CORNERS = 32
#: corners evaluated at most (all of them up to 2⁸)
MAX_CORNERS = 256
#: uniform parts drawn for starts when the caller gives none
START_PARTS = 4096
#: local maximisations on the vectorised evaluator (from the best distinct starts)
LOCAL_STARTS = 8
#: starts closer than this (in the box scaled to [-1, 1]) are one start
DISTINCT = 0.25
#: forward-difference step of the exact gradient, in the box scaled to [-1, 1]
FD_STEP = 1e-6
#: central-difference step on the vectorised evaluator (its figures carry ~1e-8 of noise)
SURROGATE_STEP = 1e-2
#: compass steps of the last stage, in the box scaled to [-1, 1]
COMPASS_STEPS = (0.5, 0.1, 0.02)
LOCAL_ITERATIONS = 30


@dataclass
class WorstCase:
    """The worst part: ``value`` is the worst δ (``quantity="ripple"``), the least
    transmission angle in degrees (``"transmission_angle"``) or the worst value of a bound's
    quantity (its key, e.g. ``"housing_radius"``), exact; ``deviation`` its offsets (mm,
    every length), ``lengths`` its design, ``evaluations`` the exact evaluations spent."""

    quantity: str
    value: float
    deviation: dict[str, float]
    lengths: dict[str, float]
    evaluations: int
    assembles: bool = True
    nominal: float | None = None
    on_corner: bool = False
    starts: int = 0
    history: list[float] = field(default_factory=list, repr=False)

    def to_dict(self) -> dict:
        key = {"ripple": "delta", "transmission_angle": "mu_min_deg"}.get(self.quantity,
                                                                           self.quantity)
        return {"quantity": self.quantity, key: self.value, f"nominal_{key}": self.nominal,
                "assembles": self.assembles, "on_corner": self.on_corner,
                "deviation_mm": self.deviation, "design": self.lengths,
                "exact_evaluations": self.evaluations, "starts": self.starts}


class _DoesNotAssemble(Exception):
    def __init__(self, u):
        self.u = u


def _worse(problem, quantity: str) -> float:
    """+1 where a larger value of ``quantity`` (δ, or a bound's key) is worse, -1 where a
    smaller one is (the transmission angle, the swing)."""
    if quantity == "ripple":
        return 1.0
    if quantity == "transmission_angle":
        return -1.0
    spec = next(s for s in problem.quantity_bounds if s.key == quantity)
    return 1.0 if get_quantity(spec.name).worst == "max" else -1.0


def _figure(r: dict, quantity: str) -> float:
    """The value of ``quantity`` in an exact part's figures (:func:`exact_part`)."""
    if quantity == "ripple":
        return r["delta"]
    if quantity == "transmission_angle":
        return r["mu_min_deg"]
    return r["quantities"][quantity]


class _Search:
    """The exact figure of the box point u ∈ [-1, 1]^d, to maximise (g = δ, g = −μ, or a
    bound's quantity with the sign that makes larger worse)."""

    def __init__(self, problem, box: Box, quantity: str, memo: dict):
        self.problem, self.box, self.quantity = problem, box, quantity
        self.memo = memo
        self.sign = _worse(problem, quantity)
        self.dims = box.toleranced
        self.evaluations = 0
        self.best_u, self.best_g = None, -np.inf
        self.history: list[float] = []

    def offsets(self, u) -> np.ndarray:
        out = np.zeros(self.box.band.size)
        out[self.dims] = np.clip(u, -1.0, 1.0) * self.box.band[self.dims]
        return out

    def value(self, u) -> float:
        u = np.clip(np.asarray(u, dtype=float), -1.0, 1.0)
        r = exact_part(self.problem, self.box.part(self.offsets(u)))
        self.evaluations += 1
        if not r["assembles"]:
            raise _DoesNotAssemble(u)
        g = self.sign * _figure(r, self.quantity)
        if g > self.best_g:
            self.best_u, self.best_g = u.copy(), g
            self.history.append(g)
        return g

    def value_and_gradient(self, u):
        """−g and −∇g (for a minimiser), the gradient by forward differences stepping
        inward from a face of the box."""
        u = np.asarray(u, dtype=float)
        g = self.value(u)
        grad = np.empty(u.size)
        for i in range(u.size):
            step = FD_STEP if u[i] + FD_STEP <= 1.0 else -FD_STEP
            v = u.copy()
            v[i] += step
            grad[i] = (self.value(v) - g) / step
        return -g, -grad


def worst_case(problem, lengths: Mapping[str, float] | None, tolerances, *,
               quantity: str = "ripple", candidates: np.ndarray | None = None,
               local_starts: int = LOCAL_STARTS, seed: int = 0,
               shared: dict | None = None) -> WorstCase:
    """The largest δ (or least transmission angle, or the worst of the quantity of the
    problem's bound keyed ``quantity``) over the tolerance box around ``lengths`` (design
    keys; missing ones at the problem's values).

    ``tolerances``: a :class:`~optdesign.tolerance.section.ToleranceSection` or
    ``{length: ± mm}``. ``candidates``: offsets (parts × the mechanism's lengths, mm), e.g.
    a Monte Carlo sample, whose worst parts are starts too. ``shared``: a dict the caller
    passes to every search of one design's box (one per quantity), so that the nominal's
    figures and the start pool's vectorised figures are computed once for them all; the
    results are the same as without it.
    """
    bounded = [s.key for s in problem.quantity_bounds]
    if quantity not in QUANTITIES + tuple(bounded):
        raise ValueError(f"quantity must be one of {', '.join(QUANTITIES + tuple(bounded))} "
                         f"(got {quantity!r})")
    box = box_of(problem, lengths, tolerances)
    search = _Search(problem, box, quantity, {} if shared is None else shared)
    d = search.dims.size
    if "nominal" not in search.memo:
        search.memo["nominal"] = exact_part(problem, box.values)
    nominal = search.memo["nominal"]
    search.evaluations += 1
    folded = np.inf * search.sign if quantity != "transmission_angle" else 0.0
    nominal_value = _figure(nominal, quantity) if nominal["assembles"] else folded
    if not nominal["assembles"] or d == 0:
        return _result(search, box, np.zeros(d), nominal["assembles"], nominal_value,
                       nominal_value, 0)
    try:
        if quantity in QUANTITIES:
            starts = _starts(problem, box, search, nominal, candidates, seed)
            chosen = _distinct(starts, local_starts)
            ends = [_surrogate_local(problem, box, search, nominal, u) for u in chosen]
            for u in _distinct([(0.0, u) for u in ends], len(ends), spacing=1e-6):
                search.value(u)
        else:
            chosen = _exact_corners(search, seed)
        _local(search, search.best_u)
        _compass(search)
    except _DoesNotAssemble as broken:
        return _result(search, box, broken.u, False, folded, nominal_value, 0)
    return _result(search, box, search.best_u, True, search.sign * search.best_g,
                   nominal_value, len(chosen))


def _exact_corners(search: _Search, seed: int) -> list[np.ndarray]:
    """The starts of a bound's worst part, each measured exactly: every corner of the box
    (up to :data:`EXACT_CORNERS`), else the corner the exact gradient at the nominal points
    to and a sample of the others."""
    d = search.dims.size
    if 2 ** d <= EXACT_CORNERS:
        corners = [2.0 * np.array(c, dtype=float) - 1.0 for c in np.ndindex(*(2,) * d)]
    else:
        _, slope = search.value_and_gradient(np.zeros(d))
        rng = np.random.default_rng(seed)
        corners = [np.where(-slope >= 0, 1.0, -1.0)] + \
            list(rng.choice([-1.0, 1.0], size=(EXACT_CORNERS - 1, d)))
    for u in corners:
        search.value(u)
    return corners


def _result(search, box, u, assembles, value, nominal, starts) -> WorstCase:
    offsets = search.offsets(u)
    on_corner = bool(search.dims.size) and bool(np.all(np.abs(np.asarray(u)) >= 1.0 - 1e-12))
    return WorstCase(search.quantity, float(value), box.deviation(offsets),
                     {k: float(v) for k, v in box.part(offsets).items()},
                     search.evaluations, assembles, float(nominal), on_corner, starts,
                     search.history)


def _starts(problem, box, search, nominal, candidates, seed) -> list[tuple[float, np.ndarray]]:
    """(score on the vectorised evaluator, u) of every start, best first."""
    d = search.dims.size
    U = _pool(box, search, candidates, seed)
    figures = _pool_figures(problem, box, search, nominal, U, candidates is None, seed)
    scores = _score(search, figures)
    slope = scores[-2 * d:-d] - scores[-d:]
    corner = np.where(slope >= 0, 1.0, -1.0)
    U, scores = U[:-2 * d], scores[:-2 * d]
    U = np.vstack([U, corner])
    scores = np.append(scores, _scores(problem, box, search, nominal, corner[None, :]))
    broken = np.isnan(scores)
    for u in U[broken][:8]:              # the fast evaluator says it fails: check exactly
        search.value(u)
    order = np.argsort(-np.where(broken, -np.inf, scores), kind="stable")
    return [(float(scores[i]), U[i]) for i in order if not broken[i]]


def _pool(box, search, candidates, seed) -> np.ndarray:
    """The unit points of the starts: the nominal, every corner (or a sample of them), the
    ``candidates`` or :data:`START_PARTS` uniform parts, and last the 2d probes of a central
    difference at the nominal (the corner the gradient points to)."""
    d = search.dims.size
    band = box.band[search.dims]
    pool = [np.zeros(d)]
    if d <= int(np.log2(MAX_CORNERS)):
        pool += [np.array(c, dtype=float) for c in np.ndindex(*(2,) * d)]
        pool[1:] = [2 * c - 1 for c in pool[1:]]
    else:
        rng = np.random.default_rng(seed)
        pool += list(rng.choice([-1.0, 1.0], size=(MAX_CORNERS, d)))
    if candidates is None:
        rng = np.random.default_rng(seed)
        pool += list(rng.uniform(-1.0, 1.0, size=(START_PARTS, d)))
    else:
        picked = np.asarray(candidates, dtype=float)[:, search.dims] / band
        pool += list(np.clip(picked, -1.0, 1.0))
    h = 1e-3
    probe = np.vstack([h * np.eye(d), -h * np.eye(d)])
    return np.vstack(pool + list(probe))


def _pool_figures(problem, box, search, nominal, U, uniform: bool, seed) -> dict:
    """The vectorised figures of the start pool ``U``; a ``uniform`` pool (no candidates) is
    the same for every quantity, and is evaluated once per memo."""
    if not uniform:
        return _figures(problem, box, search, nominal, U)
    key = ("start_pool", seed, search.dims.size)
    if key not in search.memo:
        search.memo[key] = _figures(problem, box, search, nominal, U)
    return search.memo[key]


def prime(problem, lengths: Mapping[str, float] | None, tolerances, shared: dict,
          seed: int = 0) -> None:
    """Fill ``shared`` (:func:`worst_case`'s memo) with the box's nominal and its uniform start
    pool, so that searches run apart afterwards (in forked processes) find them done."""
    box = box_of(problem, lengths, tolerances)
    search = _Search(problem, box, "ripple", shared)
    if "nominal" not in shared:
        shared["nominal"] = exact_part(problem, box.values)
    if search.dims.size and shared["nominal"]["assembles"]:
        _pool_figures(problem, box, search, shared["nominal"],
                      _pool(box, search, None, seed), True, seed)


def _scores(problem, box, search, nominal, U) -> np.ndarray:
    """g of every unit point (rows of U) on the vectorised evaluator; NaN where a part does
    not assemble."""
    return _score(search, _figures(problem, box, search, nominal, U))


def _figures(problem, box, search, nominal, U) -> dict:
    """The vectorised evaluator's figures of every unit point (rows of U)."""
    offsets = np.zeros((U.shape[0], box.band.size))
    offsets[:, search.dims] = U * box.band[search.dims]
    return evaluate_offsets(problem, box, offsets, nominal, memo=search.memo)[0]


def _score(search, figures: dict) -> np.ndarray:
    """g of the parts of ``figures``; NaN where a part does not assemble."""
    g = figures["delta"] if search.quantity == "ripple" else -figures["mu_min_deg"]
    return np.where(figures["assembles"], g, np.nan)


def _distinct(starts, count: int, spacing: float = DISTINCT) -> list[np.ndarray]:
    chosen: list[np.ndarray] = []
    for _, u in starts:
        if all(np.max(np.abs(u - c)) > spacing for c in chosen):
            chosen.append(u)
        if len(chosen) == count:
            break
    return chosen


def _surrogate_local(problem, box, search, nominal, u0: np.ndarray) -> np.ndarray:
    """The end point of L-BFGS-B maximising g on the vectorised evaluator from ``u0``: value
    and central-difference gradient in one call of 2d + 1 parts."""
    from scipy.optimize import minimize

    d = u0.size
    h = SURROGATE_STEP

    def fg(u):
        U = np.vstack([u, np.clip(u + h * np.eye(d), -1, 1), np.clip(u - h * np.eye(d), -1, 1)])
        g = _scores(problem, box, search, nominal, U)
        if not np.all(np.isfinite(g)):
            return np.inf, np.zeros(d)        # a part that fails: not a direction to take
        width = U[1:d + 1].diagonal() - U[d + 1:].diagonal()
        return -g[0], -(g[1:d + 1] - g[d + 1:]) / width

    res = minimize(fg, u0, jac=True, method="L-BFGS-B", bounds=[(-1.0, 1.0)] * d,
                   options={"maxiter": LOCAL_ITERATIONS})
    return np.clip(res.x, -1.0, 1.0)


def _local(search: _Search, u0: np.ndarray) -> None:
    from scipy.optimize import minimize

    d = u0.size
    minimize(search.value_and_gradient, u0, jac=True, method="L-BFGS-B",
             bounds=[(-1.0, 1.0)] * d,
             options={"maxiter": LOCAL_ITERATIONS, "ftol": 1e-15, "gtol": 1e-12})


def _compass(search: _Search) -> None:
    """Poll ± each axis from the best point, moving whenever a poll improves, at
    :data:`COMPASS_STEPS` in turn."""
    d = search.dims.size
    for step in COMPASS_STEPS:
        improved = True
        while improved:
            improved = False
            base_u, base_g = search.best_u.copy(), search.best_g
            for i in range(d):
                for sign in (1.0, -1.0):
                    v = base_u.copy()
                    v[i] = np.clip(v[i] + sign * step, -1.0, 1.0)
                    if v[i] == base_u[i]:
                        continue
                    search.value(v)
            improved = search.best_g > base_g + 1e-15

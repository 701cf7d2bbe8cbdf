"""Derivatives of a design's exact figures with respect to its lengths (docs/formulation.md).

For every length of the design, fixed or free, :func:`sensitivities` gives dδ/dl and
d(ratio)/dl per mm and the derivative of the transmission-angle margin (least μ − the file's
``min_transmission_angle_deg``) in degrees per mm. Every derivative is exact: CasADi's
symbolic gradients of the mechanism's θ_k, dθ_k/dφ and cos μ_k with respect to the lengths
(one function per chain, mapped over the points that need it), evaluated at the points the
exact evaluator (:mod:`optdesign.envelope.exact`) finds; no finite differences. The points
are read off the evaluation where it searched the same grid (its sampling, each run's
``stationary`` points), not searched again: one call costs a fifth to a third of an exact
check (``benchmarks/sensitivity_cost.py``).

- **ω_max, ω_min at a stationary point** of one curve (f_c' = 0): the envelope theorem,
  dω/dl = ∂f_c/∂l at (φ*, c) fixed.
- **ω_min at a hand-over** from curve a to curve b, f_a(φ_x) = f_b(φ_x): the crossing moves
  with l, and the implicit function theorem gives
  dω/dl = (f_a'·∂f_b/∂l − f_b'·∂f_a/∂l)/(f_a' − f_b').
- **The time mean**: on a run of curve c from u to v, ∫ f_c dφ = s·(θ_k(v) − θ_k(u)); the
  envelope is continuous at a hand-over, so the terms from the moving run ends cancel and
  d mean/dl = Σ runs s·(∂θ_k/∂l(v) − ∂θ_k/∂l(u))/2π, the evaluator's own sum (no quadrature).
- **δ** by its definition (``objective.ripple``): midrange, δ = 2(M − m)/(M + m); mean,
  δ = (M − m)/A; the worst over the listed eccentricities, or inside a regulation interval
  (the derivative is that of the worst e, at that e fixed, reported); **ratio** = mean/ω1 at
  e = 1. The regulating length enters the
  parameter vector as e·l, so its derivative at e carries the factor e.
- **The least transmission angle** at its arg-max of |cos μ_k| (a stationary point: the
  envelope theorem again), dμ/dl = −sign(cos μ)·(∂cos μ/∂l)/sin μ.
- **The mechanism's breakpoints** (where a speed jumps) are taken as fixed crank angles, as
  the pulse reducer's dead centres are; there the one-sided value's ∂f/∂l is used.

Where an extreme is reached by several points at once (the same peak on several curves, δ
equal at two eccentricities, two chains at the same least angle) and their slopes differ, the
figure has a kink: the value given is the right-sided derivative (for +1 mm of that length),
and ``kink`` is true with the reason in ``kinks``. Equal slopes (symmetric chains) are no
kink. A toggle (|cos μ| = 1) or a tangential hand-over is flagged the same way.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Mapping

import casadi as ca
import numpy as np

from optdesign.envelope.exact import (Curves, TOGGLE_STEP, TWO_PI, search_grid, stationary_angles,
                                      toggles)
from optdesign.envelope.sampled import ripple_of
from optdesign.errors import ProblemError
from optdesign.evaluation.design import Design
from optdesign.evaluation.figures import Evaluation, evaluate, evaluate_problem
from optdesign.mechanisms import get_mechanism

#: extremes whose values agree to this (relative) are one extreme reached at several points:
#: an optimum equalises competing extremes only to the solver's tolerance, and a step of
#: 1e-3 mm moves them apart by more
TIE_REL = 1e-7
#: tied points whose slopes differ by more than this (relative to the largest) make a kink
KINK_REL = 1e-6
#: slopes differing by less than this (per mm) are rounding noise, never a kink (the exact
#: derivative of a figure held at 0, such as an output at rest, is 0 to about 1e-11)
SLOPE_FLOOR = 1e-9
#: chains whose least transmission angle lies within this of the least (deg) are refined: the
#: evaluator's angle of a chain is exact on one side of its toggle and within ~1e-5 deg (the
#: grid's error) on the other, so no chain farther away can tie with the least
ANGLE_NEAR_DEG = 0.01


@dataclass(frozen=True)
class Sensitivities:
    """Exact derivatives of a design's figures with respect to each of its lengths."""

    d_delta: dict[str, float]             # dδ/dl, 1/mm (δ of objective.ripple, worst e)
    d_ratio: dict[str, float]             # d(ratio)/dl at e = 1, 1/mm
    d_margin: dict[str, float]            # d(least μ − bound)/dl, deg/mm
    delta: float
    ratio: float
    margin_deg: float                     # least μ − min_transmission_angle_deg
    eccentricity: float                   # the e whose δ is the worst (its derivative)
    ripple: str                           # midrange | mean
    #: (figure, reason) of every kink: figure ``delta`` or ``transmission_angle_margin``
    kinks: tuple[tuple[str, str], ...] = ()

    @property
    def kink(self) -> bool:
        return bool(self.kinks)

    def most_sensitive(self, count: int = 3) -> list[tuple[str, float]]:
        """The ``count`` lengths to which δ is most sensitive, largest |dδ/dl| first."""
        return sorted(self.d_delta.items(), key=lambda kv: -abs(kv[1]))[:count]

    def summary_line(self, count: int = 3) -> str:
        return sensitivity_line(self.to_dict(), count)

    def to_dict(self) -> dict:
        return {"d_delta_d_length_per_mm": dict(self.d_delta),
                "d_ratio_d_length_per_mm": dict(self.d_ratio),
                "d_transmission_angle_margin_d_length_deg_per_mm": dict(self.d_margin),
                "delta": self.delta, "ratio": self.ratio,
                "transmission_angle_margin_deg": self.margin_deg,
                "eccentricity": self.eccentricity, "ripple": self.ripple,
                "kink": self.kink,
                "kinks": [{"figure": f, "reason": r} for f, r in self.kinks]}


def sensitivities(problem, design_or_lengths, evaluation: Evaluation | None = None
                  ) -> Sensitivities:
    """dδ/dl, d(ratio)/dl and d(transmission-angle margin)/dl of a design, for every length.

    ``design_or_lengths``: a :class:`~optdesign.evaluation.design.Design` or the design's values (a
    :class:`SolveResult` ``.design``); ``evaluation``: its exact evaluation at the problem's
    eccentricities, if made already (a verification's), else made here. The design must
    assemble.
    """
    design = design_or_lengths if isinstance(design_or_lengths, Design) else \
        Design.from_problem(problem, dict(design_or_lengths))
    ev = evaluation or evaluate_problem(problem, design.values)
    if not ev.assembles:
        raise ProblemError(f"no sensitivities of a design that does not assemble: {ev.failure}")
    lengths = design.model.lengths
    definition = problem.objective.ripple
    delta_kinks: list[str] = []
    angle_kinks: list[str] = []
    listed = [e for e in problem.eccentricities if e in ev.eccentricities]
    per_e = {x.eccentricity: _EccentricitySlopes.of(
                 design, ev, x, delta_kinks if x.eccentricity in listed else [],
                 angle_kinks)
             for x in ev.per_e}
    for e, judged in _interval_worst(ev, definition):
        if e not in per_e:
            at = evaluate(design, ev.stroke, ev.input_speed, (e,))
            per_e[e] = _EccentricitySlopes.of(design, at, at.per_e[0],
                                              delta_kinks if judged else [], angle_kinks)
        if judged and e not in listed:
            listed.append(e)
    deltas = {e: per_e[e].delta(definition) for e in listed}
    worst = _worst(deltas, max, delta_kinks, "δ over the eccentricities")
    ratio = per_e[1.0].mean
    angle = _worst({(e, *k): s for e, x in per_e.items() for k, s in x.angles.items()},
                   min, angle_kinks, "least transmission angle over the chains")
    kinks = tuple(("delta", k) for k in delta_kinks) + \
        tuple(("transmission_angle_margin", k) for k in angle_kinks)
    bound = problem.constraints.min_transmission_angle_deg

    def named(grad):
        return {k: float(g) for k, g in zip(lengths, grad)}

    return Sensitivities(named(worst.grad), named(ratio.grad), named(angle.grad),
                         float(worst.value), float(ratio.value), float(angle.value - bound),
                         float(_worst_e(deltas)), definition, kinks)


def _interval_worst(ev: Evaluation, definition: str) -> list[tuple[float, bool]]:
    """The eccentricities inside a regulation interval where the evaluation found the worst
    δ (judged: True) and the least transmission angle (False). δ is smooth in e, so at an
    interior worst e the envelope theorem holds again: dδ/dl is taken at that e fixed."""
    worst = getattr(ev, "worst", None)            # only with a regulation interval
    if worst is None:
        return []
    out = []
    if worst.eccentricity is not None and ev.worst_definition == definition:
        out.append((float(worst.eccentricity), True))
    if worst.angle_eccentricity is not None:
        out.append((float(worst.angle_eccentricity), False))
    return out


# --------------------------------------------------------------------------- the slopes
@dataclass
class _Slope:
    """A figure and its (right-sided) gradient with respect to the design's lengths."""

    value: float
    grad: np.ndarray
    kink: str = ""              # why this point's slope is not a plain derivative


def _worst(slopes: Mapping, pick, kinks: list, what: str) -> _Slope:
    """The largest (``pick=max``) or least (``min``) of several figures, with the right-sided
    derivative where several reach it: per length the largest (least) of their slopes."""
    best = pick(s.value for s in slopes.values())
    tied = [s for s in slopes.values()
            if abs(s.value - best) <= TIE_REL * max(1.0, abs(best))]
    grads = np.array([s.grad for s in tied])
    grad = grads.max(axis=0) if pick is max else grads.min(axis=0)
    spread = np.ptp(grads, axis=0).max() if len(tied) > 1 else 0.0
    if spread > max(KINK_REL * np.abs(grads).max(), SLOPE_FLOOR):
        kinks.append(f"{what}: {len(tied)} points reach {best:.10g} with different slopes")
    kinks.extend(f"{what}: {s.kink}" for s in tied if s.kink)
    return _Slope(best, grad)


def _worst_e(deltas: Mapping[float, _Slope]) -> float:
    return max(deltas, key=lambda e: deltas[e].value)


@dataclass
class _EccentricitySlopes:
    """ω_max, ω_min, the mean (per unit ω1) and each chain's least angle at one e, with
    their gradients with respect to the design's lengths."""

    omega_max: _Slope
    omega_min: _Slope
    mean: _Slope
    angles: dict[tuple, _Slope] = field(default_factory=dict)   # (chain, side) -> μ, deg

    def delta(self, definition: str) -> _Slope:
        """δ (:func:`~optdesign.envelope.sampled.ripple_of`) and its gradient by the
        quotient rule."""
        big, small, mean = self.omega_max, self.omega_min, self.mean
        value = ripple_of(big.value, small.value, mean.value, definition)
        if definition == "midrange":
            total = big.value + small.value
            grad = 4.0 * (small.value * big.grad - big.value * small.grad) / total ** 2
            return _Slope(value, grad)
        spread = big.value - small.value
        grad = (big.grad - small.grad) / mean.value - spread * mean.grad / mean.value ** 2
        return _Slope(value, grad)

    @classmethod
    def of(cls, design: Design, ev: Evaluation, x, kinks: list,
           angle_kinks: list) -> "_EccentricitySlopes":
        """The slopes at evaluated eccentricity ``x``; the kinks of its envelope's extremes
        are added to ``kinks``, those of its transmission angles to ``angle_kinks``."""
        e, where = x.eccentricity, f"e = {x.eccentricity:g}"
        curves = Curves(design, ev.stroke, e)
        phi = search_grid(design, e)
        # the evaluation's own sampling and stationary points, where it searched this grid
        # (the same values: found again here otherwise)
        known = x.sampled is not None and x.grid is not None and np.array_equal(x.grid, phi)
        sampled = x.sampled if known else design.sample(phi, e)
        _, df = curves.stack(sampled)
        points = _Points(design, e)
        candidates = _envelope_candidates(curves, x.runs, phi, df, sampled, points, known)
        ends = _run_ends(curves, x.runs, points)
        chains = _least_angle_points(design, e, x, points)
        points.evaluate()                             # one mapped call per chain
        extremes = {i: c.slope(points, curves) for i, c in enumerate(candidates)}
        figures = x.figures[ev.stroke]
        big = _worst(extremes, max, kinks, f"ω_max at {where}")
        small = _worst(extremes, min, kinks, f"ω_min at {where}")
        _check_located(big.value, figures.omega_max / ev.input_speed, "ω_max", where, kinks)
        _check_located(small.value, figures.omega_min / ev.input_speed, "ω_min", where, kinks)
        mean = _mean_slope(curves, ends, points, figures.omega_mean / ev.input_speed)
        angles = _angle_slopes(design, x, chains, points, angle_kinks, where)
        factor = np.array([e if k == design.model.regulating_variable else 1.0
                           for k in design.model.lengths])
        for s in [big, small, mean, *angles.values()]:
            s.grad = s.grad * factor                  # ∂/∂l = ∂/∂p · dp/dl, p = e·l
        return cls(big, small, mean, angles)


def _check_located(found: float, evaluated: float, what: str, where: str, kinks: list):
    """The extreme located here must be the exact evaluator's (else say so, not pretend)."""
    if abs(found - evaluated) > 1e-9 * max(1.0, abs(evaluated)):
        kinks.append(f"{what} at {where}: located {found:.12g}, the evaluator has "
                     f"{evaluated:.12g}; the derivative is that of the located point")


# --------------------------------------------------------------------------- points
@lru_cache(maxsize=256)
def _gradient_function(mechanism: str, count: int, options: tuple, k: int) -> ca.Function:
    """(phi, p) -> θ_k, dθ_k/dφ, d²θ_k/dφ², cos μ_k and the gradients of θ_k, dθ_k/dφ and
    cos μ_k with respect to p: CasADi's symbolic derivatives of chain k's own function
    (:meth:`~optdesign.mechanisms.base.Mechanism.chain`, which the solve's NLP built already:
    the nodes of chain k alone, so the cost stays linear in n)."""
    model = get_mechanism(mechanism)
    phi, p = ca.SX.sym("phi"), ca.SX.sym("p", len(model.lengths))
    theta, dtheta, ddtheta, cos_mu, _ = model.chain(count, options, k).call([phi, p], True,
                                                                            False)
    return ca.Function(f"{model.name}_chain{k}_length_gradients_n{count}", [phi, p],
                       [theta, dtheta, ddtheta, cos_mu, ca.jacobian(theta, p),
                        ca.jacobian(dtheta, p), ca.jacobian(cos_mu, p)])


class _Points:
    """Crank angles gathered first, each with the chains it needs, then evaluated in one
    mapped call per chain; ``add`` returns the index of an angle."""

    def __init__(self, design: Design, eccentricity: float):
        self.design, self.e = design, eccentricity
        self.angles: list[float] = []
        self.needs: list[frozenset | None] = []          # None: every chain

    def add(self, phi: float, chains=None) -> int:
        self.angles.append(float(phi) % TWO_PI)
        self.needs.append(None if chains is None else frozenset(chains))
        return len(self.angles) - 1

    def evaluate(self) -> None:
        d, n_points = self.design, len(self.angles)
        n, n_p = d.count, len(d.model.lengths)
        self.theta, self.dtheta, self.ddtheta, self.cos_mu = (
            np.full((n, n_points), np.nan) for _ in range(4))        # chains × points
        self.j_theta, self.j_dtheta, self.j_cos = (
            np.full((n, n_points, n_p), np.nan) for _ in range(3))   # × lengths
        p = ca.DM(d.p(self.e))
        for k in range(n):
            idx = [i for i, need in enumerate(self.needs) if need is None or k in need]
            if not idx:
                continue
            fn = _gradient_function(d.mechanism, n, d.option_key, k)
            out = [np.array(v) for v in fn(ca.DM([self.angles[i] for i in idx]).T, p)]
            for row, v in zip((self.theta, self.dtheta, self.ddtheta, self.cos_mu), out[:4]):
                row[k, idx] = v.ravel()
            for jac, v in zip((self.j_theta, self.j_dtheta, self.j_cos), out[4:]):
                jac[k, idx] = v.reshape(len(idx), n_p)              # 1 × (points · lengths)

    def curve(self, curves: Curves, c: int, i: int) -> tuple[float, float, np.ndarray]:
        """f_c, f_c' and ∂f_c/∂p at point i (the zero curve: all zero)."""
        if c == curves.m - 1:
            return 0.0, 0.0, np.zeros(len(self.design.model.lengths))
        k, s = curves.split(c)
        return s * self.dtheta[k, i], s * self.ddtheta[k, i], s * self.j_dtheta[k, i]

    def envelope(self, curves: Curves, i: int) -> tuple[float, np.ndarray]:
        """The envelope's value and the active curve's ∂f/∂p at point i."""
        values = [self.curve(curves, c, i) for c in range(curves.m)]
        c = int(np.argmax([v[0] for v in values]))
        return values[c][0], values[c][2]


@dataclass
class _Candidate:
    """A point where the envelope may reach its max or min: ``kind`` stationary (curve c at
    f_c' = 0), handover (from curve a to curve c), breakpoint (one side), toggle (the
    one-sided limit extrapolated from points i, j)."""

    kind: str
    i: int
    c: int = -1
    a: int = -1
    j: int = -1

    def slope(self, points: _Points, curves: Curves) -> _Slope:
        if self.kind == "stationary":
            f, _, g = points.curve(curves, self.c, self.i)
            return _Slope(f, g)
        if self.kind == "handover":
            fa, da, ga = points.curve(curves, self.a, self.i)
            fb, db, gb = points.curve(curves, self.c, self.i)
            if abs(da - db) <= 1e-9 * max(abs(da), abs(db), 1.0):
                return _Slope(max(fa, fb), gb, "a tangential hand-over (the crossing's "
                                               "motion is undefined); ∂f/∂l of the new curve")
            return _Slope(max(fa, fb), (da * gb - db * ga) / (da - db))
        if self.kind == "breakpoint":
            f, g = points.envelope(curves, self.i)
            return _Slope(f, g)
        (f1, g1), (f2, g2) = points.envelope(curves, self.i), points.envelope(curves, self.j)
        angle = math.degrees(points.angles[self.i])
        return _Slope(2 * f1 - f2, 2 * g1 - g2,                       # toggle
                      f"a toggle near crank angle {angle:.4f} deg (the speed jumps; its "
                      f"one-sided limit and slope are extrapolated)")


def _chains(curves: Curves, *indices: int) -> set[int]:
    """The chains behind curves ``indices`` (the zero curve has none)."""
    return {curves.split(c)[0] for c in indices if c != curves.m - 1}


def _envelope_candidates(curves: Curves, runs, phi, df, sampled, points: _Points,
                         known: bool = False) -> list[_Candidate]:
    """Every point the exact evaluator takes the envelope's extremes from (its grid values
    never exceed them), registered with ``points``; ``known``: the runs' stationary points
    were found on ``phi`` (:attr:`~optdesign.envelope.exact.Run.stationary`)."""
    out = []
    for run in runs:
        angles = run.stationary if known and run.stationary is not None else \
            stationary_angles(curves, run, phi, df)
        out += [_Candidate("stationary", points.add(x, _chains(curves, run.curve)),
                           c=run.curve) for x in angles]
    if len(runs) > 1:
        for before, run in zip([runs[-1]] + runs[:-1], runs):
            chains = _chains(curves, before.curve, run.curve)
            out.append(_Candidate("handover", points.add(run.start, chains), c=run.curve,
                                  a=before.curve))
    for b in sorted({float(b) % TWO_PI for b in curves.design.breakpoints(curves.ecc)}):
        out += [_Candidate("breakpoint", points.add(b - 1e-10)),
                _Candidate("breakpoint", points.add(b + 1e-10))]
    for b in toggles(curves.design, curves.ecc, phi, sampled["cos_mu"]):
        h = TOGGLE_STEP
        out += [_Candidate("toggle", points.add(b - h), j=points.add(b - 2 * h)),
                _Candidate("toggle", points.add(b + h), j=points.add(b + 2 * h))]
    return out


def _run_ends(curves: Curves, runs, points: _Points) -> list[tuple]:
    """(run, index of its start, index of its end) of every run of a moving curve."""
    return [(run, points.add(run.start, _chains(curves, run.curve)),
             points.add(run.end, _chains(curves, run.curve)))
            for run in runs if run.curve != curves.m - 1]


def _mean_slope(curves: Curves, ends: list[tuple], points: _Points, mean: float) -> _Slope:
    """d mean/dl = Σ runs s·(∂θ_k/∂l(end) − ∂θ_k/∂l(start))/2π: the moving ends' terms
    cancel because the envelope is continuous at a hand-over."""
    grad = np.zeros(len(points.design.model.lengths))
    for run, u, v in ends:
        k, s = curves.split(run.curve)
        grad += s * (points.j_theta[k, v] - points.j_theta[k, u])
    return _Slope(mean, grad / TWO_PI)


def _least_angle_points(design: Design, e: float, x, points: _Points) -> dict[tuple, int]:
    """{(chain, side): point index} of each chain's largest (side 0) and least (side 1)
    cos μ, for the chains whose least transmission angle lies near the least of all, refined
    from the evaluation's grid angles by a bounded search on |cos μ| (as
    :meth:`Design.transmission_angles` does). Both sides are kept: an optimum often holds
    one chain at its bound on both."""
    if not design.model.has_transmission_angle(design.count, design.option_key):
        return {}
    least, n, h = float(x.chain_angles_deg.min()), design.count, TWO_PI / 1024
    found = {}
    for k in map(int, np.nonzero(x.chain_angles_deg <= least + ANGLE_NEAR_DEG)[0]):
        for side, start in enumerate((x.cos_extreme_angles[k], x.cos_extreme_angles[n + k])):
            angle, _ = design.largest_cos(k, start - h, start + h, e)
            found[(k, side)] = points.add(angle, (k,))
    return found


def _angle_slopes(design: Design, x, chains: dict[tuple, int], points: _Points, kinks: list,
                  where: str) -> dict:
    """Each chain's least transmission angle (deg) with dμ/dp by the envelope theorem,
    dμ = −sign(cos μ)·d cos μ / sin μ; a mechanism whose cos μ does not move with the crank
    has every chain's angle and no slope."""
    n_p = len(design.model.lengths)
    if not design.model.has_transmission_angle(design.count, design.option_key):
        return {(k, 0): _Slope(float(a), np.zeros(n_p))
                for k, a in enumerate(x.chain_angles_deg)}
    out = {}
    for (k, side), i in chains.items():
        c = float(points.cos_mu[k, i])
        if abs(c) >= 1.0 - 1e-12:
            kinks.append(f"chain {k + 1} folds (a toggle) at {where}: dμ/dl is infinite")
            out[k, side] = _Slope(0.0, np.zeros(n_p))
            continue
        grad = -np.sign(c) * points.j_cos[k, i] / math.sqrt(1.0 - c * c)
        out[k, side] = _Slope(math.degrees(math.acos(abs(c))), np.degrees(grad))
    return out


#: (mechanism, count, options) of every sensitivity record made in this process: its
#: chains' gradient functions built (:func:`made_before`)
_MADE: set = set()


def made_before(problem, count: int) -> bool:
    """Whether this process made a sensitivity record of ``problem``'s mechanism at ``count``
    phases before (its chains' gradient functions, most of a first record's time, built)."""
    return made_key(problem, count) in _MADE


def made_key(problem, count: int) -> tuple:
    """(mechanism, count, options) of :data:`_MADE` (what a record at ``count`` builds), the
    options as a design of ``problem`` names them
    (:attr:`~optdesign.evaluation.design.Design.option_key`)."""
    return (problem.mechanism, int(count),
            Design(problem.mechanism, {}, dict(problem.options)).option_key)


def sensitivity_record(problem, values: Mapping[str, float],
                       evaluation: Evaluation | None = None) -> dict:
    """:func:`sensitivities` as the block a result carries (``Sensitivities.to_dict``). A
    verified design always has one; should its derivatives fail all the same (CasADi, or an
    output at rest over the whole turn), the block says why, ``{"unavailable": reason}``,
    rather than fail the solve."""
    try:
        record = sensitivities(problem, values, evaluation).to_dict()
        design = values if isinstance(values, Design) else \
            Design.from_problem(problem, dict(values))
        _MADE.add(made_key(problem, design.count))
        return record
    except (ArithmeticError, ValueError, RuntimeError) as exc:
        return {"unavailable": f"{type(exc).__name__}: {exc}"}


def sensitivity_line(block: dict, count: int = 3) -> str:
    """One line of a :meth:`Sensitivities.to_dict` block for the terminal: the ``count``
    lengths to which δ is most sensitive, ``sensitive: dδ/dl3 = +4.67e-03 /mm, ...``, the
    worst e when it is not 1, and whether a kink makes the values one-sided."""
    slopes = block.get("d_delta_d_length_per_mm")
    if not slopes:
        return f"sensitive: n/a ({block.get('unavailable', 'no optimum')})"
    top = sorted(slopes.items(), key=lambda kv: -abs(kv[1]))[:count]
    where = "" if block["eccentricity"] == 1.0 else f" (at e = {block['eccentricity']:g})"
    return ("sensitive: " + ", ".join(f"dδ/d{k} = {v:+.2e} /mm" for k, v in top) + where
            + ("; one-sided: δ has a kink here" if any(
                k["figure"] == "delta" for k in block.get("kinks", ())) else ""))

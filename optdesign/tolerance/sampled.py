"""Thousands of parts at once: δ, ratio, least transmission angle and assembly on a crank grid.

The mechanism's speed function runs as NumPy lanes over parts × crank samples, exactly as the
solve's screening runs it (:meth:`~optdesign.mechanisms.base.Mechanism.speeds_at_once`: the
model's chains in the screening's form, the same arithmetic up to rounding).
A screening only ranks designs; a part differs from its nominal by a few hundredths of a mm,
so here every figure is refined between the samples. Between samples j and j + 1 each curve
is the cubic through its samples j-1 .. j+2 (error O(h⁴)), and

- ω_max is the active curve's stationary point on the cubics beside the highest sample;
- ω_min the crossing of the two cubics at every hand-over (Newton's method; the screening's
  linear crossing is O(h²)), or a trough inside a run; the output at rest is one more curve,
  zero, so a hand-over to rest is refined like any other;
- the time mean integrates every cell on the active curve's cubic, a hand-over cell on both
  cubics split at their crossing;
- the least transmission angle refines each chain's largest and least cos μ on its cubics.

What remains changes little over a box of tolerances: :func:`calibrated` removes the nominal
design's own error, measured once on the exact evaluator, from every part
(docs/tolerance.md gives the figures; ``tests/tolerance`` checks parts against the exact
evaluator).
"""
from __future__ import annotations

import numpy as np

from optdesign.envelope.sampled import STROKE_SIGNS, driving_speeds, ripple_of
from optdesign.evaluation.figures import eccentricities_of

#: least crank samples per turn, and per driving curve (every hand-over bracketed closely)
MIN_SAMPLES = 96
SAMPLES_PER_CURVE = 16
#: lanes (parts × samples) per call of the speed function: the arrays stay small
LANES_PER_BLOCK = 1 << 16
NEWTON_STEPS = 6


def grid_size(problem, count: int) -> int:
    curves = count * len(STROKE_SIGNS[problem.stroke])
    return max(MIN_SAMPLES, SAMPLES_PER_CURVE * curves)


def sampled_parts(problem, count: int, lengths: np.ndarray, samples: int | None = None) -> dict:
    """Figures of every row of ``lengths`` (parts × the mechanism's lengths, mm).

    Returns arrays over the parts: ``delta`` per listed eccentricity (a parts × e array, in
    the order of ``problem.eccentricities``), ``ratio`` (e = 1), ``mu_min_deg`` (least over
    the chains, the turn and every evaluated eccentricity) and ``assembles``.
    """
    lengths = np.atleast_2d(np.asarray(lengths, dtype=float))
    S = lengths.shape[0]
    N = samples or grid_size(problem, count)
    block = max(1, LANES_PER_BLOCK // N)
    out = {"delta": np.empty((S, len(problem.eccentricities))), "ratio": np.empty(S),
           "mu_min_deg": np.empty(S), "assembles": np.empty(S, dtype=bool)}
    for start in range(0, S, block):
        part = slice(start, min(start + block, S))
        for key, value in _block(problem, count, lengths[part], N).items():
            out[key][part] = value
    return out


def _block(problem, count: int, lengths: np.ndarray, N: int) -> dict:
    model = problem.model
    S = lengths.shape[0]
    fmap = model.speeds_at_once(count, tuple(sorted(problem.options.items())))
    phi = np.tile(np.linspace(0.0, 2 * np.pi, N, endpoint=False), S)[None, :]
    reg = model.lengths.index(model.regulating_variable)
    delta = np.full((S, len(problem.eccentricities)), np.nan)
    ratio = np.full(S, np.nan)
    cos_peak = np.zeros(S)
    fine = np.ones(S, dtype=bool)
    with np.errstate(all="ignore"):
        for e in eccentricities_of(problem):
            P = lengths.T.copy()
            P[reg] *= e
            dth, cos_mu = (np.asarray(v) for v in fmap(phi, np.repeat(P, N, axis=1)))
            f = driving_speeds(dth, problem.stroke).reshape(-1, S, N) / e
            hi, lo, mean = _envelope_figures(f)
            if e in problem.eccentricities:
                delta[:, problem.eccentricities.index(e)] = ripple_of(
                    hi, lo, mean, problem.objective.ripple)
            if e == 1.0:
                ratio = mean
            c = _peak_abs(cos_mu.reshape(-1, S, N))
            cos_peak = np.maximum(cos_peak, c)
            fine &= np.all(np.isfinite(f), axis=(0, 2)) & (c <= 1.0) & np.isfinite(c)
    mu = np.degrees(np.arccos(np.clip(cos_peak, 0.0, 1.0)))
    return {"delta": np.where(fine[:, None], delta, np.nan),
            "ratio": np.where(fine, ratio, np.nan),
            "mu_min_deg": np.where(fine, mu, np.nan), "assembles": fine}


# --------------------------------------------------------------------------- refinement
# Between two samples j and j + 1 a curve is the cubic through its samples j-1 .. j+2
# (t = 0 at j, 1 at j + 1): error O(h⁴) for a smooth curve, and every figure below is read
# off these cubics, so the whole turn is refined to the same order.
def _envelope_figures(f: np.ndarray):
    """(ω_max, ω_min, time mean)/ω1 of the envelope max(0, max_c f_c), f: curves × parts ×
    samples, refined between the samples. The output at rest is one more curve, zero, so a
    hand-over to rest and back is refined like any other."""
    f = np.concatenate([f, np.zeros((1,) + f.shape[1:])])
    C, S, N = f.shape
    rows = np.arange(S)
    Y = f.reshape(C * S, N)                      # row c·S + s: curve c of part s
    env = f.max(axis=0)
    active = f.argmax(axis=0)
    # ω_max: the active curve's peak in the two cells beside the envelope's highest sample
    j = env.argmax(axis=1)
    hi = _extreme_near(Y, active[rows, j] * S + rows, j, upward=False)
    # ω_min: a trough inside a run, and every hand-over
    j = env.argmin(axis=1)
    lo = _extreme_near(Y, active[rows, j] * S + rows, j, upward=True)
    # the time mean: every cell integrated on the active curve's cubic ...
    nxt = np.roll(active, -1, axis=1)
    cell = np.arange(N)[None, :].repeat(S, axis=0)
    r = (active * S + rows[:, None]).ravel()
    ym, y0, y1, y2 = (Y[r, (cell.ravel() + k) % N] for k in (-1, 0, 1, 2))
    area = ((13 * (y0 + y1) - ym - y2) / 24).reshape(S, N)
    # ... but a hand-over cell on the two curves' cubics, split where they cross
    s, j = np.nonzero(active != nxt)
    if s.size:
        a, b = active[s, j] * S + s, nxt[s, j] * S + s
        ca, cb = _cubic(Y, a, j), _cubic(Y, b, j)
        t = _crossing(ca, cb, Y[a, j] - Y[b, j], Y[a, (j + 1) % N] - Y[b, (j + 1) % N])
        np.minimum.at(lo, s, _poly(ca, t))
        area[s, j] = _integral(ca, 0.0, t) + _integral(cb, t, 1.0)
    return hi, np.maximum(lo, 0.0), area.mean(axis=1)


def _cubic(Y: np.ndarray, r, j) -> np.ndarray:
    """Coefficients (4 × cells, ascending powers of t) of the cubic through Y[r]'s samples
    j-1, j, j+1, j+2 (periodic)."""
    N = Y.shape[1]
    ym, y0, y1, y2 = (Y[r, (j + k) % N] for k in (-1, 0, 1, 2))
    return np.array([y0, -ym / 3 - y0 / 2 + y1 - y2 / 6, 0.5 * (ym - 2 * y0 + y1),
                     (-ym + 3 * y0 - 3 * y1 + y2) / 6])


def _poly(c, t):
    return c[0] + t * (c[1] + t * (c[2] + t * c[3]))


def _extreme_near(Y: np.ndarray, r, j, upward: bool) -> np.ndarray:
    """The largest (or, ``upward``, least) value of Y[r] in the cells j-1 .. j+1, from its
    cubics: the sample itself, or a stationary point of the cubic of either cell."""
    N = Y.shape[1]
    sign = -1.0 if upward else 1.0
    best = sign * Y[r, j]
    for start in ((j - 1) % N, j):
        c = sign * _cubic(Y, r, start)
        # stationary points: c1 + 2 c2 t + 3 c3 t² = 0
        qa, qb, qc = 3 * c[3], 2 * c[2], c[1]
        disc = qb * qb - 4 * qa * qc
        root = np.sqrt(np.maximum(disc, 0.0))
        linear = np.abs(qa) < 1e-14 * (np.abs(qb) + np.abs(qc) + 1e-300)
        safe = np.where(linear, 1.0, 2 * qa)
        for t in ((-qb + root) / safe, (-qb - root) / safe,
                  -qc / np.where(qb != 0, qb, 1.0)):
            t = np.where(np.isfinite(t), t, 0.0)
            inside = (t >= 0) & (t <= 1) & (disc >= 0)
            best = np.where(inside, np.maximum(best, _poly(c, np.clip(t, 0.0, 1.0))), best)
    return sign * best


def _crossing(ca, cb, gap0, gap1) -> np.ndarray:
    """t in [0, 1] where the two cubics cross: from the chords' crossing, Newton's steps."""
    t = np.clip(gap0 / np.where(gap0 != gap1, gap0 - gap1, 1.0), 0.0, 1.0)
    g = ca - cb
    for _ in range(NEWTON_STEPS):
        slope = g[1] + t * (2 * g[2] + 3 * t * g[3])
        step = _poly(g, t) / np.where(slope != 0, slope, 1.0)
        t = np.clip(t - np.where(slope != 0, step, 0.0), 0.0, 1.0)
    return t


def _integral(c, t0, t1):
    """∫ of the cubic from t0 to t1 (in units of a cell)."""
    def antiderivative(t):
        return t * (c[0] + t * (c[1] / 2 + t * (c[2] / 3 + t * c[3] / 4)))
    return antiderivative(t1) - antiderivative(t0)


def _peak_abs(cos_mu: np.ndarray) -> np.ndarray:
    """max over chains and the turn of |cos μ| (chains × parts × samples): each chain's
    largest and least cos μ refined on its cubics (both toggle sides, which an optimum often
    holds at the same angle); inf where a sample is not finite (the joints are undefined)."""
    n, S, N = cos_mu.shape
    A = cos_mu.reshape(n * S, N)
    rows = np.arange(n * S)
    with np.errstate(invalid="ignore"):
        top = _extreme_near(A, rows, np.nanargmax(np.where(np.isfinite(A), A, -np.inf),
                                                  axis=1), upward=False)
        bottom = _extreme_near(A, rows, np.nanargmin(np.where(np.isfinite(A), A, np.inf),
                                                     axis=1), upward=True)
    peak = np.maximum(top, -bottom)
    peak = np.where(np.all(np.isfinite(A), axis=1), peak, np.inf)
    return peak.reshape(n, S).max(axis=0)


# --------------------------------------------------------------------------- calibration
def calibrated(sampled: dict, nominal_sampled: dict, nominal_exact: dict) -> dict:
    """``sampled`` with the nominal design's sampling error (exact − sampled, per figure and
    per listed eccentricity) added to every part, and ``delta`` the worst over them; the
    worst δ is shifted once more by what the exact nominal δ holds beyond its listed
    eccentricities (a regulation interval's worst). Uncalibrated when the nominal does not
    assemble."""
    out = dict(sampled)
    if not nominal_exact.get("assembles") or not nominal_sampled["assembles"][0]:
        out["delta"] = np.max(sampled["delta"], axis=1)
        return out
    per_e = np.asarray(nominal_exact["delta_per_e"]) - nominal_sampled["delta"][0]
    out["delta"] = np.max(sampled["delta"] + per_e, axis=1)
    out["delta"] += nominal_exact["delta"] - max(nominal_exact["delta_per_e"])
    for key in ("ratio", "mu_min_deg"):
        out[key] = sampled[key] + (nominal_exact[key] - nominal_sampled[key][0])
    return out


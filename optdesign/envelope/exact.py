"""The exact evaluator of the output envelope: the reference for every accuracy figure.

The envelope ω_out(φ)/ω1 = max(0, max_c f_c(φ)), f_c = s·dθ_k/dφ, is piecewise smooth. Its
extremes lie at crossings of two curves (where the active rocker hands over) or at stationary
points of one (f_c' = 0, with f_c' = s·d²θ_k/dφ² from algorithmic differentiation), or at the
mechanism's breakpoints. Each is located by Brent's method on a bracket found on a grid and
refined to machine precision. The time mean needs no quadrature: on a run where curve c is
active, ∫ f_c dφ = s·(θ_k(v) - θ_k(u)), so the mean is a sum of exact angle increments.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from optdesign.envelope.sampled import STROKE_SIGNS, StrokeFigures

TWO_PI = 2 * np.pi
DEFAULT_GRID = 1024
#: a local peak of |cos μ| this close to 1 is a toggle (rod and rocker folded, μ = 0 or 180°):
#: the rocker speed jumps there, so its one-sided limits are candidate extremes. Farther from
#: 1 the speed changes steeply but smoothly, and the stationary points catch its extremes.
TOGGLE_TOL = 1e-13
#: offset of the two points each side of a toggle from which its one-sided limit is
#: extrapolated (well outside geometry.SQRT_FLOOR's ~1e-6 rad, error O(step²))
TOGGLE_STEP = 1e-4


@dataclass(frozen=True)
class Run:
    """Crank interval [start, end] on which curve ``curve`` drives the output."""

    start: float
    end: float
    curve: int          # index into the stacked curves; the last one is the output at rest
    #: the active curve's stationary points inside the run (:func:`stationary_angles` on the
    #: grid the run was found on), where :func:`exact_figures` located them; None otherwise
    stationary: tuple | None = field(default=None, compare=False)


class Curves:
    """f_c(φ) and f_c'(φ) for every (chain, sign) pair plus the zero curve (output at rest)."""

    def __init__(self, design, stroke: str, eccentricity: float):
        self.design = design
        self.ecc = eccentricity
        self.signs = STROKE_SIGNS[stroke]
        self.n = design.count
        self.m = self.n * len(self.signs) + 1
        self._chains: dict = {}          # chain k -> its bound call (Design.chain_call)
        self._ends: dict = {}            # (start, end) -> grid() at a run's two ends
        self._inside: dict = {}          # (start, end) -> (the grid, _inside() on it)

    def split(self, c: int) -> tuple[int, int]:
        return c % self.n, self.signs[c // self.n]

    def stack(self, out: dict) -> tuple[np.ndarray, np.ndarray]:
        """(f, f') of every curve at the sampled angles of ``out`` (:meth:`Design.sample`):
        s·dθ_k/dφ and s·d²θ_k/dφ² for each sign s of the stroke, then the zero curve; each
        written once into its place (the evaluator's root searches stack thousands of
        single angles)."""
        n = self.n
        dtheta = out["dtheta"].reshape(n, -1)
        ddtheta = out["ddtheta"].reshape(n, -1)
        f, df = np.empty((self.m, dtheta.shape[1])), np.empty((self.m, dtheta.shape[1]))
        for j, s in enumerate(self.signs):
            np.multiply(s, dtheta, out=f[j * n:(j + 1) * n])
            np.multiply(s, ddtheta, out=df[j * n:(j + 1) * n])
        f[-1], df[-1] = 0.0, 0.0
        return f, df

    def grid(self, phi: np.ndarray):
        out = self.design.sample(phi, self.ecc)
        f, df = self.stack(out)
        return f, df, out["theta"]

    def ends(self, run: Run):
        """:meth:`grid` at the run's two ends (its start and end, modulo 2π): read by the
        envelope's values, the stationary points' brackets and the run's angle increment,
        sampled once for the three."""
        key = (run.start, run.end)
        out = self._ends.get(key)
        if out is None:
            out = self._ends[key] = self.grid(np.mod(np.array([run.start, run.end]), TWO_PI))
        return out

    def inside(self, run: Run, phi: np.ndarray) -> np.ndarray:
        """:func:`_inside` of the run on the grid ``phi``, found once for the run's
        stationary points and its angle increment."""
        key = (run.start, run.end)
        out = self._inside.get(key)
        if out is None or out[0] is not phi:        # found on this very grid, or anew
            out = self._inside[key] = (phi, _inside(run, phi))
        return out[1]

    def point(self, phi: float):
        out = self.design.at(phi, self.ecc)
        f, df = self.stack(out)
        return f[:, 0], df[:, 0], out["theta"]

    def one(self, phi: float, c: int) -> tuple[float, float]:
        """f_c and f_c' at one angle from curve c's own chain (the root searches' inner
        loop: the other chains are not evaluated)."""
        if c == self.m - 1:
            return 0.0, 0.0
        k, s = self.split(c)
        chain = self._chains.get(k)
        if chain is None:
            chain = self._chains[k] = self.design.chain_call(k, self.ecc)
        _, dtheta, ddtheta, _, _ = chain(phi)
        return s * dtheta, s * ddtheta


def search_grid(design, eccentricity: float = 1.0, n_grid: int = DEFAULT_GRID) -> np.ndarray:
    """The crank angles the exact evaluator brackets its roots on: ``n_grid`` equal steps and
    the mechanism's breakpoints (where the speeds jump)."""
    breaks = sorted({float(b) % TWO_PI for b in design.breakpoints(eccentricity)})
    return np.union1d(np.linspace(0.0, TWO_PI, n_grid, endpoint=False), breaks)


def exact_figures(design, stroke: str, input_speed: float, eccentricity: float = 1.0,
                  n_grid: int = DEFAULT_GRID, sampled: dict | None = None,
                  phi: np.ndarray | None = None) -> tuple[StrokeFigures, list[Run]]:
    """Exact ω_max, ω_min, time mean, δ and ratio of one stroke; also the envelope's runs,
    each with the stationary points found inside it (``Run.stationary``).

    ``phi`` and ``sampled`` (``Design.sample`` on it) reuse a search grid that was sampled
    already; by default the grid is :func:`search_grid` and is sampled here.
    """
    curves = Curves(design, stroke, eccentricity)
    breaks = sorted({float(b) % TWO_PI for b in design.breakpoints(eccentricity)})
    if phi is None:
        phi = search_grid(design, eccentricity, n_grid)
        sampled = None
    if sampled is None:
        sampled = design.sample(phi, eccentricity)        # one pass: speeds and cos μ
    f, df = curves.stack(sampled)
    theta = sampled["theta"]
    runs = _runs(curves, phi, f)
    values = [f.max(axis=0).clip(min=0.0)]               # grid values: never beyond the truth
    for i, run in enumerate(runs):
        angles = stationary_angles(curves, run, phi, df)
        runs[i] = replace(run, stationary=tuple(angles))  # kept: the sensitivities' points
        values.append(_stationary_values(curves, angles))
        values.append(curves.ends(run)[0].max(axis=0))     # the envelope at its two ends
    for b in breaks:                                      # one-sided limits at jumps of f
        values.append(_envelope_at(curves, np.array([b - 1e-10, b + 1e-10])))
    for b in toggles(design, eccentricity, phi, sampled["cos_mu"]):
        h = TOGGLE_STEP
        near = _envelope_at(curves, np.array([b - 2 * h, b - h, b + h, b + 2 * h]))
        values.append(np.array([2 * near[1] - near[0], 2 * near[2] - near[3]]))
    values = np.concatenate([np.atleast_1d(v) for v in values])
    mean = sum(_increment(curves, run, phi, theta) for run in runs) / TWO_PI
    figures = StrokeFigures.from_extremes(values.max() * input_speed,
                                          values.min() * input_speed,
                                          mean * input_speed, input_speed)
    return figures, runs


def toggles(design, eccentricity: float, phi: np.ndarray,
            cos_mu: np.ndarray | None = None) -> list[float]:
    """Crank angles where a chain reaches a toggle, |cos μ| = 1 at a local peak.

    A linkage at the edge of assembly, or at the Grashof limit s + l = p + q, folds flat there
    without jamming: the half-chord of the circle intersection goes as |φ - φ0|, so the
    rocker speed jumps.
    """
    return [x for _, x, c in design.cos_peaks(phi, eccentricity, cos_mu)
            if c >= 1.0 - TOGGLE_TOL]


def _envelope_at(curves: Curves, phi: np.ndarray) -> np.ndarray:
    f, _, _ = curves.grid(np.mod(phi, TWO_PI))
    return f.max(axis=0)


def _runs(curves: Curves, phi: np.ndarray, f: np.ndarray) -> list[Run]:
    """Hand-over points of the envelope, by Brent's method on f_a - f_b between grid points."""
    active = f.argmax(axis=0)
    n = phi.size
    switches: list[tuple[float, int]] = []           # (angle, curve active after it)
    for j in np.nonzero(active != np.roll(active, -1))[0]:     # the grid cells it changes in
        a, b = active[j], active[(j + 1) % n]
        lo, hi = phi[j], phi[(j + 1) % n] + (TWO_PI if j == n - 1 else 0.0)
        switches.extend(_resolve(curves, lo, hi, a, b, depth=0))
    if not switches:
        return [Run(0.0, TWO_PI, int(active[0]))]
    switches.sort()
    runs = []
    for i, (start, curve) in enumerate(switches):
        end = switches[(i + 1) % len(switches)][0]
        if end <= start:
            end += TWO_PI
        runs.append(Run(start, end, curve))
    return runs


def _resolve(curves, lo, hi, a, b, depth) -> list[tuple[float, int]]:
    """Switch points in [lo, hi] where the envelope goes from curve a to curve b."""
    from scipy.optimize import brentq     # here: a command that only loads a file needs none

    def gap(x):
        x %= TWO_PI
        return curves.one(x, a)[0] - curves.one(x, b)[0]

    x = brentq(gap, lo, hi, xtol=1e-14, rtol=4 * np.finfo(float).eps) \
        if gap(lo) * gap(hi) < 0 else (lo if gap(lo) == 0 else hi)
    f, _, _ = curves.point(x % TWO_PI)
    if f.max() <= f[a] + 1e-12 * max(1.0, abs(f[a])) or depth > 3:
        return [(x % TWO_PI, int(b))]
    # A third curve is briefly on top inside this grid cell: look closer.
    sub = np.linspace(lo, hi, 17)
    fs, _, _ = curves.grid(np.mod(sub, TWO_PI))
    act = fs.argmax(axis=0)
    act[0], act[-1] = a, b
    out = []
    for i in range(sub.size - 1):
        if act[i] != act[i + 1]:
            out.extend(_resolve(curves, sub[i], sub[i + 1], act[i], act[i + 1], depth + 1))
    return out


def _inside(run: Run, phi: np.ndarray) -> np.ndarray:
    """Indices of grid angles strictly inside a run, in order (a run may wrap past 2π)."""
    shifted = np.mod(phi - run.start, TWO_PI)
    idx = np.nonzero((shifted > 0) & (shifted < run.end - run.start))[0]
    return idx[np.argsort(shifted[idx])]


def _stationary_values(curves: Curves, angles: list) -> np.ndarray:
    """Values of the envelope at a run's stationary points (``angles``, f' = 0)."""
    return np.array([curves.point(x % TWO_PI)[0].max() for x in angles])


def stationary_angles(curves: Curves, run: Run, phi: np.ndarray, df: np.ndarray) -> list:
    """Crank angles of the active curve's stationary points inside the run (f' = 0), each
    bracketed on the grid ``phi`` (``df``: every curve's f' there) and found by Brent's
    method; an angle may exceed 2π where the run wraps."""
    c = run.curve
    if c == curves.m - 1:
        return []
    idx = curves.inside(run, phi)
    xs = np.concatenate([[run.start], run.start + np.mod(phi[idx] - run.start, TWO_PI),
                         [run.end]])
    ends = curves.ends(run)[1][c]
    ds = np.concatenate([[ends[0]], df[c, idx], [ends[1]]])

    from scipy.optimize import brentq

    def slope(x):
        return curves.one(x % TWO_PI, c)[1]

    out = []
    for i in range(xs.size - 1):
        if ds[i] * ds[i + 1] < 0:
            try:
                out.append(brentq(slope, xs[i], xs[i + 1], xtol=1e-14,
                                  rtol=4 * np.finfo(float).eps))
            except ValueError:  # the grid's sign change lost again in rounding (lengths of
                a, b = slope(xs[i]), slope(xs[i + 1])           # 1e16 mm): the flatter end
                out.append(xs[i] if abs(a) <= abs(b) else xs[i + 1])
    return out


def _increment(curves: Curves, run: Run, phi: np.ndarray, theta: np.ndarray) -> float:
    """∫ over the run of the active curve = s·(θ_k(end) - θ_k(start)), unwrapped on the grid."""
    c = run.curve
    if c == curves.m - 1:
        return 0.0
    k, s = curves.split(c)
    idx = curves.inside(run, phi)
    th_ends = curves.ends(run)[2][k]
    path = np.concatenate([[th_ends[0]], theta[k, idx], [th_ends[1]]])
    steps = np.diff(path)
    steps = (steps + np.pi) % TWO_PI - np.pi
    return float(s * steps.sum())

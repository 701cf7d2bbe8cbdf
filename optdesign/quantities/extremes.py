"""The largest value over a crank turn of each component of a per-angle function, exactly.

A quantity such as the housing radius or the peak acceleration is an extreme over the turn of
a smooth function g(φ) of the crank angle (one component per joint or per output member).
Its extremes lie at stationary points, g'(φ) = 0, or, for a piecewise mechanism, at the
one-sided limits of its breakpoints. Each stationary point is bracketed on a grid where g'
changes sign from + to − and found by Brent's method to machine precision, with g' from
CasADi's algorithmic differentiation; the grid values are kept as candidates, so the result
never falls below what the grid shows (the same search as the output envelope's peaks,
:mod:`optdesign.envelope.exact`, over any function).
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from optdesign.numerics import user_cache
from optdesign.numerics.buffered import buffered
from optdesign.numerics.kept import keep
from optdesign.numerics.lanes import Lanes

TWO_PI = 2 * np.pi
#: offset of a breakpoint's one-sided limits (as the exact evaluator's)
BREAK_STEP = 1e-10


@dataclass(frozen=True)
class TurnMaxima:
    """The largest value of every component over the turn, and the crank angle of each."""

    values: np.ndarray           # per component
    angles: np.ndarray           # per component, radians in [0, 2π)
    #: per component: constant over the turn but for rounding (no stationary point to hold)
    constant: np.ndarray | None = None

    @property
    def value(self) -> float:
        return float(self.values.max()) if self.values.size else float("nan")


def turn_maxima(function, derivative, p: np.ndarray, phi: np.ndarray,
                breaks=(), grid: np.ndarray | None = None) -> TurnMaxima:
    """The maxima over φ of every component of ``function(φ, p)``.

    Each local maximum of a component on the grid brackets a stationary maximum between its
    two neighbours (where g' goes from + to −); Brent's method finds it on g'.

    Parameters
    ----------
    function, derivative : casadi.Function
        (φ, p) -> g (a column of m components) and (φ, p) -> dg/dφ.
    p : array
        The parameter vector (the design's lengths at an eccentricity).
    phi : array
        The grid the stationary points are bracketed on (increasing, in [0, 2π)).
    breaks : iterable of float
        Crank angles where g may jump (a piecewise mechanism's breakpoints).
    grid : array, optional
        g at ``phi`` already (components, angles), e.g. from the evaluation's sampling.
    """
    grid = _sample(function, phi, p) if grid is None else np.asarray(grid, dtype=float)
    g_at, dg_at = buffered(function), buffered(derivative)
    alone = _searched_before(derivative)        # each component on a function of its own
    values, angles = grid.max(axis=1), phi[grid.argmax(axis=1)].astype(float)
    n = phi.size
    constant = np.ptp(grid, axis=1) <= 64 * np.finfo(float).eps * np.abs(grid).max(axis=1)
    peaked = grid_peaks(grid)
    for i in range(grid.shape[0]):
        row = grid[i]
        if constant[i]:
            continue                      # constant but for rounding (a crank pin's radius)
        peaks = np.nonzero(peaked[i])[0]
        if alone and (peaks.size or len(breaks)):
            g_i, dg_i = buffered(component(function, i)), buffered(component(derivative, i))
            g_of, dg_of = (lambda t: g_i(t, p)[0]), (lambda t: dg_i(t, p)[0])
        else:
            g_of, dg_of = (lambda t: g_at(t, p)[i]), (lambda t: dg_at(t, p)[i])
        for j in peaks:
            lo = phi[j - 1] - (TWO_PI if j == 0 else 0.0)
            hi = phi[(j + 1) % n] + (TWO_PI if j == n - 1 else 0.0)
            x = _stationary(lambda t: dg_of(t % TWO_PI), lo, phi[j], hi,
                            row[j - 1], row[j], row[(j + 1) % n])
            if x is None:
                continue                  # no smooth maximum inside: the grid value stands
            v = g_of(x % TWO_PI)
            if v > values[i]:
                values[i], angles[i] = v, x % TWO_PI
        for b in breaks:
            for x in (b - BREAK_STEP, b + BREAK_STEP):
                v = g_of(x % TWO_PI)
                if v > values[i]:
                    values[i], angles[i] = v, x % TWO_PI
    return TurnMaxima(values, angles, constant)


def grid_peaks(grid: np.ndarray) -> np.ndarray:
    """Which samples of each row of ``grid`` (components × angles, periodic in the angle)
    are a peak worth refining: a local maximum (a plateau is none: its value is the grid's)
    that its second difference could lift to the row's maximum (a peak can gain at most
    about that by refining; those farther below are passed over)."""
    left, right = np.roll(grid, 1, axis=1), np.roll(grid, -1, axis=1)
    curvature = np.abs(left - 2 * grid + right)
    with np.errstate(invalid="ignore"):
        return (grid >= left) & (grid >= right) & ((grid > left) | (grid > right)) & \
            (grid + 4 * curvature >= grid.max(axis=1)[:, None]) & np.isfinite(grid)


#: the secant steps on g' stop when a step is this small (rad): g is then within
#: g''·1e-26 of its maximum
SECANT_XTOL = 1e-13
SECANT_STEPS = 8


def _stationary(slope, lo: float, mid: float, hi: float, g_lo: float, g_mid: float,
                g_hi: float) -> float | None:
    """The root of ``slope`` (g') in [lo, hi] where g' goes from + to −, or None.

    The vertex of the parabola through the three grid values is within O(h²) of the root; a
    few secant steps on g' from there converge superlinearly, with Brent's method as the
    safeguard when a step leaves the bracket."""
    denominator = g_lo - 2 * g_mid + g_hi
    x0 = mid + 0.5 * (mid - lo) * (g_lo - g_hi) / denominator if denominator < 0 else mid
    x0 = min(max(x0, lo), hi)
    h = 1e-6 * (hi - lo)
    x1 = min(x0 + h, hi) if x0 < hi else x0 - h
    s0, s1 = slope(x0), slope(x1)
    for _ in range(SECANT_STEPS):
        if s1 == s0:
            break
        x2 = x1 - s1 * (x1 - x0) / (s1 - s0)
        if not lo <= x2 <= hi:
            break
        x0, s0, x1 = x1, s1, x2
        if abs(x1 - x0) < SECANT_XTOL:
            return x1
        s1 = slope(x1)
        if s1 == 0.0:
            return x1
    s_lo, s_hi = slope(lo), slope(hi)         # the safeguard: Brent on the bracket
    if not s_lo > 0 > s_hi:
        return None
    from scipy.optimize import brentq     # here: a command that only loads a file needs none
    return brentq(slope, lo, hi, xtol=1e-14, rtol=4 * np.finfo(float).eps)


def _sample(function, phi: np.ndarray, p: np.ndarray) -> np.ndarray:
    """``function`` at every grid angle: (components, angles), as NumPy lanes where the
    function translates, else through CasADi's ``map``."""
    lanes = lanes_of(function)
    if lanes is not None:
        return lanes(phi[None, :], p[:, None])[0]
    mapped = function.map(phi.size)
    return np.array(mapped(phi[None, :], np.tile(p[:, None], (1, phi.size))))


#: the functions searched so far, by id: (the function, how often it was searched, its
#: symbolic inputs and outputs once made, the components' functions made); at most
#: :data:`SEARCHED_KEPT`, the oldest let go first (a worker of an atlas meets many counts)
_SEARCHED: dict = {}
SEARCHED_KEPT = 64


def _record(function) -> list:
    """``function``'s entry in :data:`_SEARCHED` (made on first use)."""
    known = _SEARCHED.get(id(function))
    if known is None or known[0] is not function:
        known = keep(_SEARCHED, SEARCHED_KEPT, id(function), [function, 0, None, {}])
    return known


def _searched_before(function) -> bool:
    """Whether ``function`` was searched before in this process (and count this search). A
    process that searches a function once (a solve's answer) calls it whole; one that
    searches it again (a warm process: the explorer, a front's or an atlas's worker, the
    next solve) makes each component a function of its own (:func:`component`): building
    them costs about what two searches save (the disc problem at 24 phases: 48 components
    per quantity, a search 37 ms whole, 11 ms by component)."""
    known = _record(function)
    known[1] += 1
    return known[1] > 1


def component(function, i: int):
    """(φ, p) -> component ``i`` of ``function``'s first output, a function of its own cut
    from one symbolic call of ``function`` (an SX function holds only the nodes that
    component needs, so a search along it does not evaluate the others: the same operations
    on the same values, the same result to the bit)."""
    known = _record(function)
    if known[2] is None:
        kind = ca.SX if function.is_a("SXFunction") else ca.MX
        args = [kind.sym(function.name_in(k), function.sparsity_in(k))
                for k in range(function.n_in())]
        known[2] = (args, ca.vec(function.call(args)[0]))
    made = known[3]
    if i not in made:
        args, outputs = known[2]
        made[i] = ca.Function(f"{function.name()}_{i}", args, [outputs[i]])
    return made[i]


#: the lanes of the functions sampled so far, by function and ``OPTDESIGN_COMPILE`` (None:
#: the function does not translate)
_LANES: dict = {}


def lanes_of(function):
    """The NumPy lanes of ``function``, made once per ``OPTDESIGN_COMPILE`` in use (None
    where it does not translate): lanes decide as they are made whether their loop runs
    compiled, as a mechanism's do (:meth:`~optdesign.mechanisms.base.Mechanism.lanes_made`)."""
    key = (id(function), user_cache.mode())
    known = _LANES.get(key)
    if known is None or known[0] is not function:
        try:
            lanes = Lanes(function)
        except NotImplementedError:
            lanes = None
        known = _LANES[key] = (function, lanes)
    return known[1]

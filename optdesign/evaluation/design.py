"""A concrete design: one mechanism, its phase count, options and link lengths, evaluated numerically."""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Mapping

import numpy as np

from optdesign.errors import AssemblyError
from optdesign.mechanisms import get_mechanism
from optdesign.numerics.buffered import buffered

#: |cos μ| may exceed 1 by this much and still count as assembled: none, since past 1 the
#: floored square root of geometry.circle_intersection puts a spurious spike in the speed
ASSEMBLY_TOL = 0.0
#: grids of at least this many angles are evaluated as NumPy lanes (CasADi's arithmetic, a
#: fixed cost per instruction that pays from a few hundred angles on); shorter ones by CasADi
LANES_FROM = 256
TWO_PI = 2 * np.pi


def _cell(phi: np.ndarray, j: int) -> tuple[float, float]:
    """The crank angles of grid point j's two neighbours, unwrapped around it."""
    n = phi.size
    return (phi[j - 1] - (TWO_PI if j == 0 else 0.0),
            phi[(j + 1) % n] + (TWO_PI if j == n - 1 else 0.0))


@dataclass(frozen=True)
class Design:
    """Every design key at a value; the numeric face of the symbolic mechanism."""

    mechanism: str
    values: Mapping[str, float]
    options: Mapping[str, str] = field(default_factory=dict)
    #: the parameter vector per eccentricity, made once: the exact evaluator's root searches
    #: make thousands of single-angle calls per design
    _p: dict = field(default_factory=dict, init=False, compare=False, repr=False)

    @classmethod
    def from_problem(cls, problem, values: Mapping[str, float] | None = None) -> "Design":
        v = problem.start_values() | dict(values or {})
        return cls(problem.mechanism, v, dict(problem.options))

    @property
    def model(self):
        return get_mechanism(self.mechanism)

    @property
    def count(self) -> int:
        return int(round(self.values[self.model.count_variable]))

    @cached_property
    def option_key(self) -> tuple[tuple[str, str], ...]:
        return tuple(sorted((self.model.default_options() | dict(self.options)).items()))

    def function(self):
        """The mechanism's ``casadi.Function`` (phi, p) -> (theta, dtheta, ddtheta, cos_mu)."""
        return self.model.kinematics(self.count, self.option_key)

    def p(self, eccentricity: float = 1.0) -> np.ndarray:
        """Parameter vector, the regulating length scaled by the eccentricity fraction e."""
        reg = self.model.regulating_variable
        return np.array([self.values[k] * (eccentricity if k == reg else 1.0)
                         for k in self.model.lengths], dtype=float)

    def scaled(self, factor: float) -> "Design":
        """All lengths times ``factor`` (a change of unit): δ and the ratio must not change."""
        lengths = set(self.model.lengths)
        return Design(self.mechanism, {k: v * factor if k in lengths else v
                                       for k, v in self.values.items()}, self.options)

    def p_fixed(self, eccentricity: float = 1.0) -> np.ndarray:
        """:meth:`p`, made once per eccentricity (read-only)."""
        if eccentricity not in self._p:
            self._p[eccentricity] = self.p(eccentricity)
            self._p[eccentricity].flags.writeable = False
        return self._p[eccentricity]

    def breakpoints(self, eccentricity: float = 1.0) -> tuple[float, ...]:
        values = dict(zip(self.model.lengths, self.p(eccentricity))) | {
            self.model.count_variable: self.count}
        return tuple(self.model.breakpoints(values, self.count))

    # ------------------------------------------------------------------ evaluation
    def sample(self, phi: np.ndarray, eccentricity: float = 1.0) -> dict[str, np.ndarray]:
        """theta, dtheta, ddtheta (chains × samples) and cos_mu at the crank angles ``phi``."""
        phi = np.atleast_1d(np.asarray(phi, dtype=float))
        if phi.size >= LANES_FROM:
            try:
                out = self.model.kinematic_lanes(self.count, self.option_key)(
                    phi[None, :], self.p(eccentricity)[:, None])
                return dict(zip(("theta", "dtheta", "ddtheta", "cos_mu"), out))
            except NotImplementedError:
                pass
        fmap = self.model.mapped(self.count, self.option_key, phi.size)
        flat = buffered(fmap)(phi, np.tile(self.p(eccentricity), phi.size))
        out, start = {}, 0
        for i, key in enumerate(("theta", "dtheta", "ddtheta", "cos_mu")):
            rows, cols = fmap.size_out(i)
            out[key] = flat[start:start + rows * cols].reshape((rows, cols), order="F")
            start += rows * cols
        return out

    def at(self, phi: float, eccentricity: float = 1.0) -> dict[str, np.ndarray]:
        """The same at one crank angle (vectors over chains)."""
        out = buffered(self.model.packed(self.count, self.option_key))(
            float(phi), self.p_fixed(eccentricity))
        return dict(zip(("theta", "dtheta", "ddtheta", "cos_mu"), out.reshape(4, -1)))

    def chain_at(self, phi: float, k: int, eccentricity: float = 1.0) -> tuple[float, ...]:
        """θ_k, dθ_k/dφ, d²θ_k/dφ², cos μ_k and d cos μ_k/dφ of chain k alone at one crank
        angle (the other chains are not evaluated)."""
        return self.chain_call(k, eccentricity)(phi)

    def chain_call(self, k: int, eccentricity: float = 1.0):
        """:meth:`chain_at` of chain k at ``eccentricity`` as a function of the crank angle
        alone, its CasADi call bound once: a root search's inner loop, which calls it a few
        dozen times. It holds this thread's buffers (:func:`buffered`): call it in the
        thread that made it."""
        call = buffered(self.model.chain(self.count, self.option_key, k))
        p = self.p_fixed(eccentricity)
        return lambda phi: tuple(call(float(phi), p).tolist())

    def largest_cos(self, k: int, lo: float, hi: float, eccentricity: float = 1.0,
                    xatol: float = 1e-12) -> tuple[float, float]:
        """(angle, |cos μ_k|) of chain k's largest |cos μ| between the crank angles ``lo`` and
        ``hi`` (the chain closest to folding there), by a bounded scalar search: the one
        search every check, figure and sensitivity of the transmission angle refines with."""
        from scipy.optimize import minimize_scalar

        chain = self.chain_call(k, eccentricity)
        res = minimize_scalar(lambda x: -abs(chain(x % TWO_PI)[3]),
                              bounds=(lo, hi), method="bounded", options={"xatol": xatol})
        return float(res.x), float(-res.fun)

    def cos_peaks(self, phi: np.ndarray, eccentricity: float = 1.0,
                  cos_mu: np.ndarray | None = None, near: float = 1e-3):
        """Local peaks of |cos μ| of every chain with |cos μ| > 1 - ``near`` on the grid
        ``phi``, refined between the neighbouring samples: [(chain, angle, |cos μ|)].

        Where |cos μ| peaks the chain is closest to folding (μ -> 0 or 180°); a peak above 1
        between two samples is a failure to assemble that the samples alone would miss.
        """
        if cos_mu is None:
            cos_mu = self.sample(phi, eccentricity)["cos_mu"]
        a = np.abs(cos_mu)
        out = []
        # every chain's peaks at once, chain by chain and in angle order within a chain
        peaks = (a >= np.roll(a, 1, axis=1)) & (a >= np.roll(a, -1, axis=1)) & \
            (a > 1.0 - near) & np.isfinite(a)
        for k, j in zip(*np.nonzero(peaks)):
            k, j = int(k), int(j)
            x, c = self.largest_cos(k, *_cell(phi, j), eccentricity)
            x, c = (x, c) if c > a[k, j] else (phi[j], a[k, j])
            out.append((k, float(x % TWO_PI), float(c)))
        return out

    def check_assembly(self, eccentricity: float = 1.0, n_samples: int = 2048,
                       phi: np.ndarray | None = None, cos_mu: np.ndarray | None = None) -> None:
        """Raise :class:`AssemblyError` naming the first chain and crank angle that fail.

        A chain assembles while the discriminant 1 - cos²μ >= 0 (the circle intersection of
        :mod:`optdesign.mechanisms.geometry`); the failing angle is located by bisection to
        1e-9 rad. Peaks of |cos μ| near 1 are refined between the samples, so a chain that
        fails only between two samples is caught too. ``phi`` and ``cos_mu`` reuse a grid
        that was already sampled (an :class:`~optdesign.evaluation.figures.Evaluation`).
        """
        if phi is None:
            phi = np.linspace(0.0, 2 * np.pi, n_samples, endpoint=False)
        if cos_mu is None:
            cos_mu = self.sample(phi, eccentricity)["cos_mu"]
        bad = ~(np.abs(cos_mu) <= 1.0)
        if not bad.any():
            for chain, angle, c in self.cos_peaks(phi, eccentricity, cos_mu):
                if c > 1.0 + ASSEMBLY_TOL:
                    raise AssemblyError(chain + 1, float(np.degrees(angle)) % 360.0,
                                        f"the rod and rocker cannot reach each other; "
                                        f"eccentricity {eccentricity:g}")
            return
        j = int(np.argmax(bad.any(axis=0)))
        chain = int(np.argmax(bad[:, j]))
        lo, hi = (phi[j - 1], phi[j]) if j > 0 else (phi[j], phi[j])
        if j > 0:
            at = self.chain_call(chain, eccentricity)
            for _ in range(40):
                mid = 0.5 * (lo + hi)
                if abs(at(mid)[3]) <= 1.0:
                    lo = mid
                else:
                    hi = mid
        c = cos_mu[chain, j]
        detail = ("the rod and rocker cannot reach each other" if np.isfinite(c)
                  else "joint positions undefined")
        raise AssemblyError(chain + 1, float(np.degrees(hi)) % 360.0,
                            f"{detail}; eccentricity {eccentricity:g}")

    def transmission_angles(self, eccentricity: float = 1.0, n_grid: int = 720,
                            phi: np.ndarray | None = None,
                            cos_mu: np.ndarray | None = None) -> np.ndarray:
        """Least transmission angle min(μ, 180° - μ) of every chain over the turn, in degrees.

        The worst angle is where |cos μ| peaks: found on a grid (``phi``, sampled already as
        ``cos_mu``, or ``n_grid`` equal steps), then refined by a bounded scalar search on the
        neighbouring cells.
        """
        if phi is None:
            phi = np.linspace(0.0, 2 * np.pi, n_grid, endpoint=False)
        if cos_mu is None:
            cos_mu = self.sample(phi, eccentricity)["cos_mu"]
        # a mechanism whose cos μ does not move with the crank (a slotted lever) has its
        # least angle at every sample: no search between them
        moves = self.model.has_transmission_angle(self.count, self.option_key)
        worst = []
        for k in range(cos_mu.shape[0]):
            j = int(np.argmax(np.abs(cos_mu[k])))
            c = abs(cos_mu[k, j])
            if moves:
                c = self.largest_cos(k, *_cell(phi, j), eccentricity, xatol=1e-10)[1]
            c = min(max(c, abs(cos_mu[k, j])), 1.0)
            worst.append(np.degrees(np.arccos(c)))          # min(μ, 180° - μ) = acos|cos μ|
        return np.array(worst)

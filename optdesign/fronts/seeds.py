"""Global starts for the ε points: the solve's screening of the box, run once per phase count
and re-filtered for each ε.

``optdesign solve`` screens a Sobol sample of the box and polishes the best basins
(:mod:`optdesign.solver.screening`). A sweep screens each phase count the same way once, keeping
every screened design's sampled δ and ratio; an ε point then takes the designs whose sampled
ratio reaches ε, ranks them by sampled δ and picks the best basins among them (a design seeds
a basin when no better passing design lies within the screening's critical distance). So a
point is polished from the best regions of the box that meet its bound, not only from its
neighbour on the chain, at the cost of a filter, not of a new screening.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from optdesign.fronts.axis import axis_of
from optdesign.solver.screening import screen

#: a screened design passes ε when its sampled ratio is at least ε·(1 − RATIO_SLACK): the
#: coarse grid's ratio is within a fraction of a per cent of the exact one, and a start just
#: below ε is still a good start
RATIO_SLACK = 2e-3


@dataclass
class ScreenedCount:
    """One phase count's screened designs: their values, sampled δ and ratio (the gain, on a
    front against another quantity), whether they pass every filter but the ratio bound, and
    their place in the unit box."""

    count: int
    values: list[dict]
    delta: np.ndarray
    ratio: np.ndarray
    feasible: np.ndarray
    unit: np.ndarray
    radius: float
    free: tuple[str, ...]
    lower: np.ndarray
    span: np.ndarray

    @classmethod
    def of(cls, problem, count: int) -> "ScreenedCount":
        """Screen ``problem.solver.screen`` designs of one count (the solve's own sample)."""
        sampled: dict = {}
        s = screen(problem, count, problem.solver.screen, sampled=sampled)
        free = tuple(problem.free_lengths())
        lower = np.array([problem.design[k].lower for k in free], float)
        upper = np.array([problem.design[k].upper for k in free], float)
        n = len(s.candidates)
        delta = sampled.get("delta", np.full(n, np.inf))
        axis = axis_of(problem)         # the gain: the ratio, or sign·the swept quantity
        ratio = sampled.get("ratio", np.full(n, -np.inf)) if axis.is_ratio else \
            axis.sign * np.asarray(sampled.get("quantities", {}).get(axis.name,
                                                                     np.full(n, np.nan)))
        ok = np.array([c.feasible for c in s.candidates], bool) & np.isfinite(delta) & \
            np.isfinite(ratio)
        values = [{k: float(v) for k, v in c.values.items()} for c in s.candidates]
        return cls(count, values, np.asarray(delta, float),
                   np.asarray(ratio, float), ok,
                   np.array([c.unit for c in s.candidates]).reshape(n, len(free)),
                   float(s.radius), free, lower, np.where(upper > lower, upper - lower, 1.0))

    def position(self, values: dict) -> np.ndarray:
        """A design's place in the unit box of the free lengths."""
        return (np.array([values[k] for k in self.free], float) - self.lower) / self.span

    def seeds(self, epsilon: float, n: int, near: list[dict] = ()) -> list[dict]:
        """Up to ``n`` basin seeds for ratio >= ``epsilon``, best sampled δ first; a basin
        within the critical distance of a design in ``near`` (the chain's own start) is
        skipped: that start covers it."""
        if n <= 0 or not len(self.values):
            return []
        reach = epsilon * (1 - RATIO_SLACK) if epsilon >= 0 else epsilon * (1 + RATIO_SLACK)
        passing = np.flatnonzero(self.feasible & (self.ratio >= reach))
        order = passing[np.argsort(self.delta[passing], kind="stable")]
        points = self.unit[order]
        covered = [self.position(v) for v in near if v]
        out: list[dict] = []
        for rank, i in enumerate(order):
            u = points[rank]
            if rank and np.min(np.linalg.norm(points[:rank] - u, axis=1)) <= self.radius:
                continue            # a better passing design lies close: not a basin's seed
            if any(np.linalg.norm(u - c) <= self.radius for c in covered):
                continue
            out.append(dict(self.values[i]))
            if len(out) >= n:
                break
        return out

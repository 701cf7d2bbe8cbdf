"""How benchmarks/pareto_vs_peers.py scores fronts: pure functions of (δ, ratio) points.

Both objectives are minimised, f = (δ, −ratio), as in `optdesign.fronts.indicators`. One
normalisation per problem, z = (f − ideal)/(nadir − ideal), with the ideal and nadir of the
non-dominated union of every method's verified final front (a zero span counts as 1), and one
reference point z_ref = (1.1, 1.1), so every method's hypervolume is on the same scale (at most
1.1² = 1.21). The hypervolume itself is moocore's (`moocore.hypervolume`), which ignores points
that do not strictly dominate the reference point.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

REFERENCE = (1.1, 1.1)


def objectives(delta, ratio) -> np.ndarray:
    """The (n, 2) array of minimised objectives (δ, −ratio)."""
    return np.column_stack([np.asarray(delta, float).reshape(-1),
                            -np.asarray(ratio, float).reshape(-1)])


def non_dominated(f: np.ndarray) -> np.ndarray:
    """Boolean mask of the rows of ``f`` (minimised, finite) that no other row dominates; of
    exact duplicates one is kept."""
    import moocore

    f = np.asarray(f, float).reshape(-1, 2)
    if len(f) == 0:
        return np.zeros(0, bool)
    return np.asarray(moocore.is_nondominated(f, keep_weakly=False), bool)


@dataclass(frozen=True)
class Normalisation:
    """The one normalisation of a problem: ideal and nadir in (δ, −ratio)."""

    ideal: tuple[float, float]
    nadir: tuple[float, float]
    reference: tuple[float, float] = REFERENCE

    @classmethod
    def of_fronts(cls, fronts: list[np.ndarray]) -> "Normalisation":
        """Ideal and nadir of the non-dominated union of ``fronts`` (each (n, 2), minimised)."""
        union = np.vstack([np.asarray(f, float).reshape(-1, 2) for f in fronts])
        if len(union) == 0:
            raise ValueError("no verified point in any front: nothing to normalise on")
        union = union[non_dominated(union)]
        return cls(tuple(map(float, union.min(axis=0))), tuple(map(float, union.max(axis=0))))

    def normalise(self, f: np.ndarray) -> np.ndarray:
        ideal, nadir = np.asarray(self.ideal), np.asarray(self.nadir)
        span = np.where(nadir - ideal > 0, nadir - ideal, 1.0)
        return (np.asarray(f, float).reshape(-1, 2) - ideal) / span

    def hypervolume(self, f: np.ndarray) -> float:
        """moocore's hypervolume of the normalised points against the reference point."""
        import moocore

        z = self.normalise(f)
        if len(z) == 0:
            return 0.0
        return float(moocore.hypervolume(z, ref=np.asarray(self.reference, float)))

    def to_dict(self) -> dict:
        return {"ideal": {"delta": self.ideal[0], "ratio": -self.ideal[1]},
                "nadir": {"delta": self.nadir[0], "ratio": -self.nadir[1]},
                "reference_point_normalised": list(self.reference),
                "largest_hypervolume": self.reference[0] * self.reference[1]}


def domination_margin(ours: list[dict], peer: list[dict], same_count: bool = False):
    """How far a peer's point beats one of ours in δ at equal or higher ratio.

    margin = max (δ_o − δ_p) over our points o and the peer's points p with ratio_p ≥ ratio_o
    (and, with ``same_count``, the same phase count). Positive: the peer found a design with at
    least our ratio and a δ lower by that much, so our point is dominated; zero or negative:
    no peer point dominates ours, and the value is the closest approach. Points are dicts with
    ``delta``, ``ratio`` and ``phases``. Returns None when no pair qualifies, else a dict with
    the margin, its size relative to δ_o, and the two points.
    """
    best = None
    for o in ours:
        for p in peer:
            if p["ratio"] < o["ratio"] or (same_count and p["phases"] != o["phases"]):
                continue
            m = o["delta"] - p["delta"]
            if best is None or m > best["margin"]:
                best = {"margin": m, "relative": m / o["delta"] if o["delta"] else math.inf,
                        "ours": {k: o[k] for k in ("phases", "delta", "ratio")},
                        "peer": {k: p[k] for k in ("phases", "delta", "ratio")}}
    return best


def format_margin(m) -> str:
    """A margin as the results table shows it: bold when a peer dominates one of ours."""
    if m is None:
        return "no pair"
    if m["margin"] <= 0:
        return f"none ({m['margin']:+.1e})"
    return f"**{m['margin']:+.1e}** ({100 * m['relative']:+.1f} %, n = {m['ours']['phases']})"


def checkpoint_times(t_ours: float, budget: float, n: int = 8) -> list[float]:
    """n log-spaced times from budget/100 to the budget, and our own time if within it."""
    times = set(np.geomspace(budget / 100, budget, n).tolist())
    if t_ours <= budget:
        times.add(float(t_ours))
    return sorted(times)


def value_at(curve: list[tuple[float, float]], t: float) -> float:
    """The last value of a (time, value) step curve at or before t; 0 before its first step."""
    before = [v for s, v in curve if s <= t + 1e-12]
    return before[-1] if before else 0.0


def thin(f: np.ndarray, k: int) -> np.ndarray:
    """Indices of at most k non-dominated rows of ``f`` keeping the most hypervolume: the least
    contributor (on the set's own normalisation, reference 1.1) is dropped one at a time, as
    SMS-EMOA's survival does. In two objectives a point's contribution is the rectangle its two
    neighbours leave it, so only those change when it goes: a heap makes the greedy
    O(n log n) (a smooth one-dimensional front keeps every evaluated design, 10⁵ of them)."""
    import heapq

    f = np.asarray(f, float).reshape(-1, 2)
    keep = np.flatnonzero(non_dominated(f))
    if len(keep) <= k:
        return keep
    z = Normalisation(tuple(f[keep].min(axis=0)), tuple(f[keep].max(axis=0))).normalise(
        f[keep])
    order = np.lexsort((z[:, 1], z[:, 0]))          # by the first objective; the second falls
    x, y = z[order, 0], z[order, 1]
    n = len(order)
    left, right = list(range(-1, n - 1)), list(range(1, n + 1))
    alive = [True] * n
    rx, ry = REFERENCE

    def contribution(i: int) -> float:
        x_next = x[right[i]] if right[i] < n else rx
        y_prev = y[left[i]] if left[i] >= 0 else ry
        return (x_next - x[i]) * (y_prev - y[i])

    heap = [(contribution(i), i) for i in range(n)]
    heapq.heapify(heap)
    remaining = n
    while remaining > k:
        c, i = heapq.heappop(heap)
        if not alive[i] or c != contribution(i):
            continue                                  # removed, or a stale contribution
        alive[i], remaining = False, remaining - 1
        a, b = left[i], right[i]
        if a >= 0:
            right[a] = b
            heapq.heappush(heap, (contribution(a), a))
        if b < n:
            left[b] = a
            heapq.heappush(heap, (contribution(b), b))
    return np.sort(keep[order[np.flatnonzero(alive)]])
    z = Normalisation(tuple(f[keep].min(axis=0)), tuple(f[keep].max(axis=0))).normalise(
        f[keep])
    ref = np.asarray(REFERENCE, float)
    while len(keep) > k:
        worst = int(np.argmin(moocore.hv_contributions(z, ref=ref)))
        keep = np.delete(keep, worst)
        z = np.delete(z, worst, axis=0)
    return keep


def beaten_optima(claims: list[dict], rel: float = 1e-6) -> int:
    """How many points called ``optimal`` another verified design of their count beats on
    their own ε-problem (less δ at a ratio of at least their ε; for the least-ripple end, less
    δ at any ratio; for the largest-ratio end, a larger ratio), every figure the exact
    verification's. The peers claim no ε-optimum:
    their points are an archive, so the check is of ours."""
    out = 0
    for p in claims:
        if p["status"] != "optimal":
            continue
        mine = [q for q in claims if q is not p and q["phases"] == p["phases"]]
        less = [q for q in mine if q["delta"] < p["delta"] * (1 - rel)]
        if p["kind"] == "least_ripple":
            beaten = bool(less)
        elif p["kind"] == "sweep" and p["epsilon"] is not None:
            beaten = any(q["ratio"] >= p["epsilon"] * (1 - 1e-9) for q in less)
        else:                       # the largest-ratio end: a larger ratio, or as much for less
            beaten = any(q["ratio"] > p["ratio"] * (1 + rel) for q in mine) or \
                any(q["ratio"] >= p["ratio"] * (1 - 1e-9) for q in less)
        out += beaten
    return out

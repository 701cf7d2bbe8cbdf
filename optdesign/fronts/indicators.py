"""Non-dominated filtering and quality indicators of a ripple/ratio front.

Both objectives are stated as minimisation: f1 = δ (ripple), f2 = -ratio. Indicators work in
*normalised* objective space, z = (f - ideal) / (nadir - ideal), where ideal and nadir are the
component-wise best and worst values over the non-dominated points being judged (a span of
zero is taken as 1). The hypervolume's reference point is z_ref = (1.1, 1.1), the usual 10 %
margin beyond the nadir, so the extreme points contribute too; the largest value a front can
reach is 1.1² = 1.21.
"""
from __future__ import annotations

import numpy as np

REFERENCE = (1.1, 1.1)


def objectives(delta, ratio) -> np.ndarray:
    """The (n, 2) array of minimised objectives (δ, -ratio)."""
    return np.column_stack([np.asarray(delta, float), -np.asarray(ratio, float)])


def non_dominated(f: np.ndarray) -> np.ndarray:
    """Boolean mask of the rows of ``f`` (minimised) that no other row dominates.

    Row a dominates row b when a <= b in every objective and a < b in one. Of exact
    duplicates the first is kept, so a front never lists one design twice.
    """
    f = np.asarray(f, float)
    n = len(f)
    keep = np.ones(n, bool)
    for i in range(n):
        le = np.all(f <= f[i], axis=1)
        lt = np.any(f < f[i], axis=1)
        if np.any(le & lt):
            keep[i] = False
        elif np.any(le[:i] & ~lt[:i] & keep[:i]):      # an earlier exact duplicate
            keep[i] = False
    return keep


def normalise(f: np.ndarray, ideal=None, nadir=None):
    """(z, ideal, nadir): f mapped so the ideal is (0, 0) and the nadir (1, 1)."""
    f = np.asarray(f, float)
    ideal = f.min(axis=0) if ideal is None else np.asarray(ideal, float)
    nadir = f.max(axis=0) if nadir is None else np.asarray(nadir, float)
    span = np.where(nadir - ideal > 0, nadir - ideal, 1.0)
    return (f - ideal) / span, ideal, nadir


def hypervolume_2d(z: np.ndarray, reference=REFERENCE) -> float:
    """Exact area dominated by the points ``z`` (minimised) and bounded by ``reference``.

    Sort the non-dominated points by z1; each adds the rectangle between its z1, the next
    point's z1 (or the reference) and its z2 up to the reference: a staircase sum.
    """
    z = np.asarray(z, float).reshape(-1, 2)
    r = np.asarray(reference, float)
    z = z[np.all(z < r, axis=1)]
    if len(z) == 0:
        return 0.0
    z = z[non_dominated(z)]
    z = z[np.argsort(z[:, 0])]
    right = np.append(z[1:, 0], r[0])
    return float(np.sum((right - z[:, 0]) * (r[1] - z[:, 1])))


def spacing(z: np.ndarray) -> float:
    """Schott's spacing: spread of each point's L1 distance to its nearest neighbour.

    S = sqrt(Σ (d̄ - d_i)² / (n - 1)), d_i = min_j≠i |z_i - z_j|_1; 0 for evenly spaced points,
    undefined (NaN) for fewer than two.
    """
    z = np.asarray(z, float).reshape(-1, 2)
    if len(z) < 2:
        return float("nan")
    d = np.abs(z[:, None, :] - z[None, :, :]).sum(axis=2)
    np.fill_diagonal(d, np.inf)
    d = d.min(axis=1)
    return float(np.sqrt(np.sum((d.mean() - d) ** 2) / (len(z) - 1)))


def knee(z: np.ndarray) -> int:
    """Index of the knee (best compromise) of a normalised front.

    The point farthest from the chord joining the front's two extremes; with fewer than three
    points (no chord to bend away from), the point nearest to the ideal (0, 0).
    """
    z = np.asarray(z, float).reshape(-1, 2)
    if len(z) == 0:
        raise ValueError("an empty front has no knee")
    order = np.argsort(z[:, 0])
    a, b = z[order[0]], z[order[-1]]
    chord = b - a
    length = float(np.hypot(*chord))
    if len(z) < 3 or length == 0:
        return int(np.argmin(np.hypot(z[:, 0], z[:, 1])))
    # signed distance from the chord; negative on the ideal's side (a convex bend)
    dist = (chord[0] * (z[:, 1] - a[1]) - chord[1] * (z[:, 0] - a[0])) / length
    return int(np.argmin(dist)) if np.min(dist) < 0 else int(np.argmin(np.hypot(z[:, 0],
                                                                              z[:, 1])))


def value_knee(front: np.ndarray, sign: float = 1.0) -> int | None:
    """Index of the knee of a front ``(δ, −gain)`` on the values' own scales: the design of
    the most gain per unit of ripple, the largest ``sign·ln(value) − ln δ`` (value = sign·gain,
    the quantity itself: the ratio, or a housing radius with sign −1). Past it each per cent
    more of the quantity costs more than a per cent more ripple (the elasticity
    d ln δ / d ln value crosses 1 there), before it less. None where a value or a δ is not
    positive (no per cent to speak of): the chord's knee then stands."""
    delta, value = front[:, 0], -sign * front[:, 1]
    if len(front) < 2 or not (np.all(delta > 0) and np.all(value > 0)):
        return None
    return int(np.argmax(sign * np.log(value) - np.log(delta)))


def indicators(delta, ratio, ideal=None, nadir=None, name: str = "ratio",
               sign: float = 1.0, flat_below: float | None = None,
               at_rest: float | None = None) -> dict:
    """Hypervolume, spacing and knee of the non-dominated subset of (δ, ratio) points; a
    front of one design has neither hypervolume nor spacing (None), not the ideal's value.
    ``ratio`` may be any gain (larger better) of the quantity ``name``, gain = sign·value:
    the ideal and the nadir then name the quantity's own values.

    The knee is :func:`value_knee`'s, on the values' own scales (``knee_rule``
    ``"per_ripple"``), else the chord's in the normalised front (``"chord"``). A front whose δ
    spans less than ``flat_below`` (the δ resolution a designer reads) is *flat*: δ is the
    same to them over the whole front, so the knee is the end of the largest gain (``flat``
    true, ``knee_rule`` ``"flat"``).

    ``at_rest``: the δ of a design whose output comes to rest once a turn (the midrange δ
    2(ω_max − ω_min)/(ω_max + ω_min) is 2 where ω_min = 0), the largest any design has. Such
    a design is never the knee, where the front holds another: past where δ stops growing
    the ratio per unit of ripple grows without limit, and the per-ripple rule would pick the
    design that stalls (``knee_at_rest_excluded`` counts the designs left out)."""
    f = objectives(delta, ratio)
    mask = non_dominated(f) if len(f) else np.zeros(0, bool)
    front = f[mask]
    if len(front) == 0:
        return {"n_points": 0, "hypervolume": 0.0, "spacing": float("nan"), "knee": None,
                "flat": False, "knee_rule": None}
    flat = flat_below is not None and len(front) > 1 and \
        float(np.ptp(front[:, 0])) < flat_below
    z, ideal, nadir = normalise(front, ideal, nadir)
    # the knee's candidates: the front's designs that do not come to rest, where it has any
    moving = np.ones(len(front), bool) if at_rest is None else \
        front[:, 0] < at_rest * (1 - 1e-9)
    if not moving.any():
        moving[:] = True
    among = np.flatnonzero(moving)
    by_value = None if flat else value_knee(front[among], sign)
    if flat:
        k, rule = int(among[np.argmin(front[among, 1])]), "flat"
    elif by_value is not None:
        k, rule = int(among[by_value]), "per_ripple"
    else:
        k, rule = int(among[knee(z[among])]), "chord"
    single = len(front) == 1        # no trade-off: the normalisation has nothing to span
    return {"n_points": int(len(front)), "flat": bool(flat), "knee_rule": rule,
            "knee_at_rest_excluded": int(len(front) - len(among)),
            "hypervolume": None if single else hypervolume_2d(z),
            "spacing": None if single else spacing(z),
            "knee": int(np.flatnonzero(mask)[k]),
            "reference_point_normalised": list(REFERENCE),
            "ideal": {"delta": float(ideal[0]), name: float(-sign * ideal[1])},
            "nadir": {"delta": float(nadir[0]), name: float(-sign * nadir[1])}}

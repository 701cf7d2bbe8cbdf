"""A derivative-free refinement on the exact check, where IPOPT cannot polish a known design.

IPOPT needs a start whose hand-overs, peaks and stationary points its NLP can hold. Near a
dead point (a slotted lever's pivot distance approaching its crank, a pulse reducer's crank
approaching its pivot) the output speed's peak grows without bound and sharpens, and a start
there can leave the NLP's rows so far from consistent that IPOPT wanders off to a poorer design
or runs out of iterations; an objective pushed towards such a point (the largest swing, the
largest peak speed) has its optimum on the box's face beside it. The solve still knows designs
there: the screening's, and where an unconverged polish stopped. :func:`refine` improves the
best of them by the Nelder-Mead simplex (:func:`scipy.optimize.minimize`, bounded; its
first simplex small, a step of :data:`STEP` on each length, so that it searches beside the
start and expands towards a face that improves) on the exact check alone, in the screening's unit box (a range of decades in its logarithm),
within :data:`EVALUATIONS` exact checks. It certifies nothing beyond what the check does: the
design it returns meets every constraint, and is never worse than the one it started from.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.optimize import minimize

from optdesign.solver.screening import spread, unit_of
from optdesign.solver.verify import verify

#: exact checks one refinement may spend
EVALUATIONS = 80
#: the first simplex's edge, in the unit box (a fiftieth of each range)
STEP = 0.02
#: a design the check rejects scores this (the simplex needs a finite value)
REJECTED = 1e300


def refine(problem, values: dict, key: float) -> dict | None:
    """Free lengths better than ``values`` (whose exact key is ``key``) by the Nelder-Mead simplex
    on the exact check within the box, or None when none is found."""
    free = problem.free_lengths()
    if not free or not math.isfinite(key):
        return None
    lower = np.array([problem.design[k].lower for k in free])
    upper = np.array([problem.design[k].upper for k in free])
    base = dict(values)
    best = {"key": key, "values": None}

    def design(u: np.ndarray) -> dict:
        x = spread(np.clip(u, 0.0, 1.0)[None, :], lower, upper)[0]
        return base | {k: float(v) for k, v in zip(free, x)}

    def score(u: np.ndarray) -> float:
        trial = design(u)
        ver = verify(problem, trial, search=False)
        if not ver.feasible or not math.isfinite(ver.key):
            return REJECTED
        if ver.key < best["key"]:
            best.update(key=ver.key, values=trial)
        return float(ver.key)

    u0 = np.clip(unit_of(np.array([[values[k] for k in free]], dtype=float),
                         lower, upper)[0], 0.0, 1.0)
    # a small simplex around the start: a step towards the box's far side on each length
    simplex = np.vstack([u0] + [u0 + np.where(np.arange(len(free)) == j,
                                              STEP if u0[j] + STEP <= 1.0 else -STEP, 0.0)
                                for j in range(len(free))])
    minimize(score, u0, method="Nelder-Mead", bounds=[(0.0, 1.0)] * len(free),
             options={"maxfev": EVALUATIONS, "initial_simplex": simplex,
                      "xatol": 1e-9, "fatol": 1e-12})
    return best["values"]

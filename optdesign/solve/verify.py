"""Exact re-verification of a design against a problem's criteria.

Every optimum the NLP returns passes through here: one :class:`~optdesign.evaluation.Evaluation`
(the exact evaluator's δ, ratio and hand-over structure, the transmission angle refined between
samples), then every criterion of :func:`optdesign.criteria.constraints_of` checks itself on it.
A design is feasible only if this says so, whatever the surrogate believed.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..criteria import (TOL_ANGLE_DEG, TOL_LENGTH_REL, TOL_RATIO, Measured,
                        SectionConstraint, constraints_of, objective_of)
from ..errors import AssemblyError
from ..evaluation import Evaluation, eccentricities_of, evaluate_problem
from .nlp import tag_of

#: the tolerances and the eccentricity order are the criteria's and the evaluation's; they are
#: importable from here too, where the exact check is
__all__ = ["TOL_ANGLE_DEG", "TOL_LENGTH_REL", "TOL_RATIO", "Verification", "checks",
           "eccentricities_of", "start_guess", "verify"]


@dataclass
class Verification:
    feasible: bool
    delta: float | None = None            # worst ripple over the listed eccentricities
    ratio: float | None = None            # at e = 1
    min_angle_deg: float | None = None    # least transmission angle over every listed e
    violations: dict[str, float] = field(default_factory=dict)
    message: str = ""
    evaluation: Evaluation | None = None
    measured: Measured | None = None
    key: float = math.inf                 # the objective's ranking key (lower is better)

    @property
    def eccentricities(self) -> tuple[float, ...]:
        return self.evaluation.eccentricities if self.evaluation else ()

    @property
    def sequences(self) -> tuple[tuple[int, ...], ...]:
        """Hand-over order per eccentricity; empty when the design does not assemble."""
        if self.evaluation is None or not self.evaluation.assembles:
            return ()
        return tuple(x.sequence for x in self.evaluation.per_e)

    @property
    def figures(self) -> list:
        ev = self.evaluation
        return [x.figures[ev.stroke] for x in ev.per_e] if ev and ev.assembles else []

    def regulation(self) -> list[dict]:
        return [{"eccentricity": e, **f.to_dict()} for e, f in
                zip(self.eccentricities, self.figures)]


def verify(problem, values: dict[str, float]) -> Verification:
    """Exact figures of ``values`` and every constraint of ``problem`` checked on them."""
    ev = evaluate_problem(problem, values)
    if not ev.assembles:
        kind = "assembly" if isinstance(ev.failure, AssemblyError) else "geometry"
        return Verification(False, violations={kind: math.inf}, message=str(ev.failure),
                            evaluation=ev)
    m = Measured.of(problem, ev)
    ver = Verification(True, delta=m.worst_ripple, ratio=m.ratio,
                       min_angle_deg=m.min_angle_deg, evaluation=ev, measured=m,
                       key=objective_of(problem).key(m))
    for criterion, amount, holds in checks(problem, m):
        if not holds:
            ver.violations[criterion.name] = amount
            ver.feasible = False
            if isinstance(criterion, SectionConstraint):
                ver.message = criterion.message(problem, m)
    return ver


def checks(problem, m: Measured) -> list[tuple]:
    """Every constraint of ``problem`` checked on the measured design ``m``: (criterion, its
    violation (<= 0 when met), whether it holds within the criterion's tolerance)."""
    out = []
    for criterion in constraints_of(problem):
        amount = float(criterion.violation(problem, m))
        out.append((criterion, amount, amount <= criterion.tolerance(m)))
    return out


def start_guess(nlp, ver: Verification) -> dict:
    """Initial values of every NLP variable from the exact evaluation of a design."""
    ev, w1 = ver.evaluation, nlp.problem.input_speed
    values = ev.design.values
    guess = {"lengths": [values[k] / s for k, s in zip(nlp.free, nlp.scale)],
             "worst_ripple": [ver.delta]}
    for e, x in zip(nlp.eccs, ev.per_e):
        tag = tag_of(e)
        fig = x.figures[ev.stroke]
        guess[f"w_{tag}"] = [fig.omega_max / (w1 * e), fig.omega_min / (w1 * e)]
        guess[f"phi_peak_{tag}"] = x.peak_angles
        guess[f"phi_mu_{tag}"] = x.cos_extreme_angles
        handovers = x.handovers
        pad = np.full(nlp.slots - handovers.size, handovers[0] if handovers.size else 0.0)
        guess[f"phi_handover_{tag}"] = np.concatenate([handovers, pad])
    return guess

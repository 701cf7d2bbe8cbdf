"""Exact re-verification of a design against a problem's criteria.

Every optimum the NLP returns passes through here: one :class:`~optdesign.evaluation.figures.Evaluation`
(the exact evaluator's δ, ratio and hand-over structure, the transmission angle refined between
samples), then every criterion of :func:`optdesign.quantities.criteria.constraints_of` checks itself on it.
A design is feasible only if this says so, whatever the surrogate believed.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from optdesign.errors import AssemblyError
from optdesign.evaluation.figures import Evaluation, eccentricities_of, evaluate_problem
from optdesign.quantities import get_quantity
from optdesign.quantities.criteria import (Measured, SectionConstraint, TOL_ANGLE_DEG,
                                           TOL_LENGTH_REL, TOL_RATIO, constraints_of, objective_of)
from optdesign.solver.nlp import Held, scenario_tag

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
    #: the solve's eccentricity slots, evaluated after the listed eccentricities
    held: Held = Held()
    #: a robust solve's scenario parts (``held.offsets``), each evaluated at e = 1 and the
    #: listed eccentricities (None: the part does not assemble)
    scenarios: list = field(default_factory=list)
    #: a robust solve: the tolerance analysis's worst parts (WorstCase of the ripple and of
    #: the transmission angle) of this design, once checked
    worst_cases: tuple = ()
    #: ... and the box's corners that break a constraint on the lengths or the ratio floor
    corners: dict = field(default_factory=dict)

    @property
    def eccentricities(self) -> tuple[float, ...]:
        return self.evaluation.eccentricities if self.evaluation else ()

    @property
    def sequences(self) -> tuple[tuple[int, ...], ...]:
        """Hand-over order per eccentricity; empty when the design does not assemble."""
        if self.evaluation is None or not self.evaluation.assembles:
            return ()
        return tuple(x.sequence for x in self.blocks())

    def blocks(self) -> list:
        """The evaluation of every eccentricity block of the NLP, in its order: e = 1 and the
        listed ones, the held slots, then each scenario part's (the nominal's where a part
        does not assemble: the NLP's assembly rows then bring it back)."""
        return [x for _, x in self.designed_blocks()]

    def designed_blocks(self) -> list[tuple]:
        """(design, evaluation) of every block of :meth:`blocks`: a scenario part's blocks
        are its own design's."""
        ev = self.evaluation
        out = [(ev.design, x) for x in ev.per_e]
        n = len(out) - len(self.held.eccentricities)
        for part in self.scenarios:
            out += [(part.design, x) for x in part.per_e] if part is not None else out[:n]
        return out

    @property
    def figures(self) -> list:
        ev = self.evaluation
        return [x.figures[ev.stroke] for x in ev.per_e] if ev and ev.assembles else []

    def regulation(self) -> list[dict]:
        """Exact figures per listed eccentricity (e = 1 first; not the solve's slots)."""
        listed = len(self.eccentricities) - len(self.held.eccentricities)
        return [{"eccentricity": e, **f.to_dict()} for e, f in
                zip(self.eccentricities[:listed], self.figures[:listed])]

    @property
    def worst_eccentricity(self) -> float | None:
        """With a regulation interval: the e of the largest δ over the interval (exact)."""
        ev = self.evaluation
        return ev.worst.eccentricity if ev is not None and ev.worst is not None else None


def verify(problem, values: dict[str, float], held: Held | None = None,
           search: bool = True) -> Verification:
    """Exact figures of ``values`` and every constraint of ``problem`` checked on them; with
    a regulation interval, over the whole interval (its worst δ and transmission angle;
    without ``search``, at its ends only: a start's check, before any polish), and evaluated
    at the ``held`` slots' eccentricities too (for the NLP's start)."""
    held = held if held is not None else Held.idle(problem)
    ev = evaluate_problem(problem, values, extra=held.eccentricities, search=search)
    if not ev.assembles:
        kind = "assembly" if isinstance(ev.failure, AssemblyError) else "geometry"
        return Verification(False, violations={kind: math.inf}, message=str(ev.failure),
                            evaluation=ev, held=held)
    m = Measured.of(problem, ev)
    ver = Verification(True, delta=m.worst_ripple, ratio=m.ratio,
                       min_angle_deg=m.min_angle_deg, evaluation=ev, measured=m,
                       key=objective_of(problem).key(m), held=held,
                       scenarios=[_part(problem, values, o) for o in held.offsets])
    for criterion, amount, holds in checks(problem, m):
        if not holds:
            ver.violations[criterion.name] = amount
            ver.feasible = False
            if isinstance(criterion, SectionConstraint):
                ver.message = criterion.message(problem, m)
    return ver


def _part(problem, values, offsets):
    """The evaluation of one scenario part (None when it does not assemble)."""
    values = problem.start_values() | dict(values)
    part = values | {k: float(values[k]) + o for k, o in zip(problem.model.lengths, offsets)}
    ev = evaluate_problem(problem, part, search=False)
    return ev if ev.assembles else None


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
    for tag, (design, x) in zip(nlp.tags, ver.designed_blocks()):
        fig = x.figures[ev.stroke]
        e = x.eccentricity
        guess[f"w_{tag}"] = [fig.omega_max / (w1 * e), fig.omega_min / (w1 * e)]
        guess[f"phi_peak_{tag}"] = x.peak_angles
        guess[f"phi_mu_{tag}"] = x.cos_extreme_angles
        handovers = x.handovers
        pad = np.full(nlp.slots - handovers.size, handovers[0] if handovers.size else 0.0)
        guess[f"phi_handover_{tag}"] = np.concatenate([handovers, pad])
        for name in nlp.turn:
            for part, value in get_quantity(name).start_angles(design, e, x.sampled).items():
                guess[f"{'phi_q' if part == 'angles' else part}_{name}_{tag}"] = value
    variables = {block.name for block in nlp.layout.x}
    for spec in nlp.specs:
        if f"quantity_{spec.key}" not in variables:
            continue                    # the NLP reads the figure itself: nothing to start
        # the epigraph in the NLP's figure (cos²μ of the least angle)
        value = get_quantity(spec.name).to_figure(ver.measured.quantities[spec.key])
        guess[f"quantity_{spec.key}"] = [value]
        for j in range(nlp.n_scenarios):     # a part's own value: near the nominal's
            guess[f"quantity_{spec.key}_{scenario_tag(j)}"] = [value]
    return guess

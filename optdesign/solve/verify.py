"""Exact re-verification of a design against a problem's constraints.

Every optimum the NLP returns passes through here: the exact evaluator (optdesign.exact) gives
δ, the ratio and the hand-over structure; the transmission angle is refined between samples.
A design is feasible only if this says so, whatever the surrogate believed.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..analysis import transmission_angles
from ..design import Design
from ..errors import AssemblyError, ProblemError
from ..exact import exact_figures

#: Tolerances of the exact check: a constraint violated by less is taken as met.
TOL_ANGLE_DEG = 1e-3
TOL_RATIO = 1e-7
#: length constraints (pin radius, Grashof), relative to the design's longest length:
#: 4e-5 mm at 400 mm, far below any manufacturing tolerance, and the same in any unit.
TOL_LENGTH_REL = 1e-7


@dataclass
class Verification:
    feasible: bool
    delta: float | None = None            # worst ripple over the listed eccentricities
    ratio: float | None = None            # at e = 1
    min_angle_deg: float | None = None    # least transmission angle over every listed e
    violations: dict[str, float] = field(default_factory=dict)
    sequences: tuple[tuple[int, ...], ...] = ()
    handovers: list[np.ndarray] = field(default_factory=list)
    figures: list = field(default_factory=list)      # StrokeFigures per eccentricity
    eccentricities: tuple[float, ...] = ()
    message: str = ""

    def regulation(self) -> list[dict]:
        return [{"eccentricity": e, **f.to_dict()} for e, f in
                zip(self.eccentricities, self.figures)]


def eccentricities_of(problem) -> tuple[float, ...]:
    """e = 1 first (where the ratio is defined), then the other listed fractions."""
    return (1.0,) + tuple(e for e in problem.eccentricities if e != 1.0)


def verify(problem, values: dict[str, float]) -> Verification:
    """Exact figures of ``values`` and every constraint of ``problem`` checked on them."""
    design = Design.from_problem(problem, values)
    model = design.model
    try:
        model.check_values(design.values, design.count)
    except ProblemError as exc:
        return Verification(False, violations={"geometry": math.inf}, message=str(exc))
    eccs = eccentricities_of(problem)
    ver = Verification(True, eccentricities=eccs)
    angles = []
    for e in eccs:
        try:
            design.check_assembly(e, n_samples=720)
        except AssemblyError as exc:
            return Verification(False, violations={"assembly": math.inf}, message=str(exc),
                                eccentricities=eccs)
        figures, runs = exact_figures(design, problem.stroke, problem.input_speed, e)
        ver.figures.append(figures)
        ver.sequences += (tuple(r.curve for r in runs),)
        ver.handovers.append(np.array([r.start for r in runs]))
        angles.append(float(transmission_angles(design, e).min()))
    listed = [i for i, e in enumerate(eccs) if e in problem.eccentricities]
    definition = problem.objective.ripple
    ver.delta = max(ver.figures[i].ripple(definition) for i in listed)
    ver.ratio = ver.figures[0].ratio
    ver.min_angle_deg = min(angles)
    c = problem.constraints
    _violated(ver, "transmission_angle", c.min_transmission_angle_deg - ver.min_angle_deg,
              TOL_ANGLE_DEG)
    _violated(ver, "min_ratio", problem.objective.min_ratio - ver.ratio, TOL_RATIO)
    if problem.objective.minimize == "-ratio":
        _violated(ver, "max_ripple", ver.delta - problem.objective.max_ripple, TOL_RATIO)
    lengths = {k: design.values[k] for k in model.lengths}
    tol_length = TOL_LENGTH_REL * max(abs(v) for v in lengths.values())
    for name, g in model.design_constraints(lengths, design.count, c):
        _violated(ver, name, -float(g), tol_length)
    if c.grashof and hasattr(model, "grashof_constraints"):
        for name, g in model.grashof_constraints(lengths):
            _violated(ver, name, -float(g), tol_length)
    sections_verify = [(k, s) for k, s in problem.sections.items() if hasattr(s, "verify")]
    if sections_verify:
        from ..analysis import analyze
        try:
            analysis = analyze(problem, design.values)
        except ProblemError as exc:          # e.g. the shaft would run past its critical speed
            ver.feasible = False
            ver.violations["sections"] = math.inf
            ver.message = str(exc)
            return ver
        for key, section in sections_verify:
            message = section.verify(problem, analysis)
            if message:
                ver.violations[key] = math.inf
                ver.feasible = False
                ver.message = message
    return ver


def _violated(ver: Verification, name: str, amount: float, tol: float) -> None:
    if amount > tol:
        ver.violations[name] = float(amount)
        ver.feasible = False

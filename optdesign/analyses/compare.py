"""Candidate designs side by side: the optimum, the robust optimum, a Pareto pick.

Each design is a problem with its design fixed (a ``design.yaml``, or the problem beside a
solve's ``result.json``), analysed exactly (:func:`optdesign.analyses.analyze.analyze`): its
lengths, count, δ, ratio, least transmission angle and every quantity, and the tolerance
box's worst δ when its result holds one (a robust solve). Their output speeds over the turn
are drawn on one figure.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from optdesign.analyses.analyze import analyze, ripples_of_analysis
from optdesign.envelope.sampled import output_envelope
from optdesign.errors import AssemblyError
from optdesign.evaluation.design import Design


@dataclass
class Candidate:
    """One design to compare: a label, its problem (the design fixed) and what its result
    file adds (the robust solve's worst δ over the tolerance box)."""

    label: str
    problem: object
    extra: dict = field(default_factory=dict)


def compare(candidates: list[Candidate]) -> list[dict]:
    """One row per candidate: ``label``, ``mechanism``, the count, each length (mm),
    ``delta``, ``ratio``, ``min_transmission_angle_deg`` (exact, at the problem's listed
    eccentricities), ``delta_label`` and ``delta_eccentricity`` (which δ that is and where it
    falls, :mod:`optdesign.evaluation.ripples`), every quantity's value, and the result's
    extras."""
    rows = []
    for c in candidates:
        result = analyze(c.problem)
        problem = c.problem
        row = {"label": c.label, "mechanism": problem.mechanism,
               "count": int(Design.from_problem(problem).count)}
        row |= {k: float(v) for k, v in result.design.items() if k in problem.model.lengths}
        if result.assembles:
            ripple = problem.objective.ripple
            figures = result.quantities.get("values", {})
            named = ripples_of_analysis(problem, result)
            row |= {"delta": figures.get("ripple"), "ratio": figures.get("ratio"),
                    "min_transmission_angle_deg": result.min_transmission_angle_deg,
                    "ripple_definition": ripple}
            if named is not None:
                row |= {"delta_label": named.worst.label,
                        "delta_eccentricity": named.worst.eccentricity}
            row |= {k: v for k, v in figures.items()
                    if k not in ("ripple", "ratio", "transmission_angle")}
        else:
            row["assembles"] = False
        rows.append(row | c.extra)
    return rows


def envelopes(candidates: list[Candidate], samples: int = 721,
              eccentricities: dict | None = None) -> dict[str, tuple]:
    """label -> (crank angle [deg], output speed [rad/s]) of each candidate at e = 1, or at
    its eccentricity in ``eccentricities`` ({label: e}; e.g. where its worst δ falls)."""
    phi = np.linspace(0.0, 2 * np.pi, samples)
    out = {}
    for c in candidates:
        design = Design.from_problem(c.problem)
        e = (eccentricities or {}).get(c.label) or 1.0
        try:
            design.check_assembly(e)
        except AssemblyError:       # a design that does not assemble has no envelope to draw
            continue
        dtheta = design.sample(phi, e)["dtheta"]
        out[c.label] = (np.degrees(phi),
                        output_envelope(dtheta, c.problem.stroke) * c.problem.input_speed)
    return out

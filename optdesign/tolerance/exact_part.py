"""One part on the exact evaluator: the figures the tolerance analysis reports, exactly."""
from __future__ import annotations

from typing import Mapping

from optdesign.errors import ProblemError
from optdesign.evaluation.figures import evaluate_problem
from optdesign.quantities.criteria import measured_quantities


def exact_part(problem, values: Mapping[str, float]) -> dict:
    """δ (the worst over the listed eccentricities, and a regulation interval if the problem
    has one: as the solve's objective defines it; per listed eccentricity in
    ``delta_per_e``), the ratio (e = 1), the least transmission angle (every
    chain, the whole turn, every evaluated eccentricity), whether the part assembles, and
    ``quantities``: the exact value of every quantity a bound of the problem names, by the
    bound's key (:func:`~optdesign.quantities.criteria.measured_quantities`). A part that
    does not assemble has δ = inf, the ratio NaN, μ = 0 (it folds) and no quantities."""
    ev = evaluate_problem(problem, values)
    if isinstance(ev.failure, ProblemError) or not ev.assembles:
        return {"assembles": False, "delta": float("inf"),
                "delta_per_e": [float("inf")] * len(problem.eccentricities),
                "ratio": float("nan"), "mu_min_deg": 0.0, "quantities": {}}
    definition = problem.objective.ripple
    per_e = [ev.at(e).figures[problem.stroke].ripple(definition)
             for e in problem.eccentricities]
    return {"assembles": True, "delta": ev.ripple(definition, problem.eccentricities),
            "delta_per_e": per_e, "ratio": ev.ratio, "mu_min_deg": ev.min_angle_deg,
            "quantities": measured_quantities(problem, ev)}

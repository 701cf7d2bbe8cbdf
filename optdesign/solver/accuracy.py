"""The ``accuracy`` record of every solve result: which evaluators a solve used and their
estimated errors at the optimum it returns (the benchmark of every evaluator against run time
is :mod:`optdesign.analyses.accuracy`, ``optdesign bench accuracy``)."""
from __future__ import annotations

import math

import numpy as np

from optdesign.envelope.exact import DEFAULT_GRID
from optdesign.evaluation.design import Design
from optdesign.evaluation.figures import eccentricities_of, evaluate, refined
from optdesign.quantities.criteria import TOL_ANGLE_DEG, TOL_LENGTH_REL, TOL_RATIO

#: the accuracy record's search grid, this many times finer than the exact evaluator's
FINER = 4


def refined_figures(problem, design: Design, e: float):
    """The exact figures of ``design`` at ``e`` on the accuracy record's finer grid
    (:func:`~optdesign.evaluation.figures.refined`, remembered: a solve may refine a count's
    best optimum ahead, while it waits for a polish beside it)."""
    return refined(design, problem.stroke, problem.input_speed, e, FINER)


def solve_accuracy(problem, best) -> dict:
    """The ``accuracy`` dict of a :class:`~optdesign.solver.result.SolveResult`.

    Which evaluators were used and, at the returned optimum ``best`` (a PhaseResult or None),
    their estimated errors:

    * ``exact_error_estimate``: largest change of δ and of the ratio over the listed
      eccentricities when the exact evaluator's search grid is refined from ``exact_grid`` to
      :data:`FINER`·``exact_grid`` (its root finding is to 1e-14 rad, so this is ~1e-15
      unless a run or a stationary point was missed);
    * ``surrogate_gap``: the NLP's δ minus the exact δ at the optimum (the log-sum-exp part of
      the surrogate only matters at minima inside a run; hand-overs and peaks are exact);
    * ``transmission_angle_sample_gap_deg``: least transmission angle at the NLP's crank samples
      minus the exact least angle (what sampling the constraint misses; the driver tightens the
      NLP's bound by it and re-solves when the exact check fails).
    """

    s = problem.solver
    out = {"verification": "exact evaluator (crossings and stationary points by Brent's "
                           "method; mean from exact angle increments)",
           "nlp_samples": s.samples, "nlp_smoothing": s.smoothing,
           "verification_tolerance_angle_deg": TOL_ANGLE_DEG,
           "verification_tolerances": {"angle_deg": TOL_ANGLE_DEG, "ratio": TOL_RATIO,
                                       "length_relative": TOL_LENGTH_REL},
           "exact_grid": DEFAULT_GRID,
           "exact_error_estimate": None, "surrogate_gap": None,
           "transmission_angle_sample_gap_deg": None,
           "benchmark": "optdesign bench accuracy (docs/accuracy.md)"}
    if best is None or best.design is None:
        return out
    design = Design.from_problem(problem, best.design)
    d_delta = d_ratio = 0.0
    phi = np.linspace(0.0, 2 * np.pi, s.samples, endpoint=False)
    sampled_angle = math.inf
    for e in eccentricities_of(problem):          # e = 1 (the ratio) and the listed ones
        # the grid the answer was verified on: that evaluation, from the evaluator's memory
        coarse = evaluate(design, problem.stroke, problem.input_speed, (e,)).per_e[0] \
            .figures[problem.stroke]
        fine = refined_figures(problem, design, e)
        definition = problem.objective.ripple
        if e in problem.eccentricities:
            d_delta = max(d_delta, abs(coarse.ripple(definition) - fine.ripple(definition)))
        if e == 1.0:
            d_ratio = abs(coarse.ratio - fine.ratio)
        cos_mu = np.abs(design.sample(phi, e)["cos_mu"]).clip(max=1.0)
        sampled_angle = min(sampled_angle, float(np.degrees(np.arccos(cos_mu.max()))))
    out["exact_error_estimate"] = {"delta": d_delta, "ratio": d_ratio}
    out["surrogate_gap"] = best.surrogate_gap
    if best.min_transmission_angle_deg is not None:
        out["transmission_angle_sample_gap_deg"] = sampled_angle - \
            best.min_transmission_angle_deg
    return out

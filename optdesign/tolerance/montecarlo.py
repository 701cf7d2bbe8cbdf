"""Monte Carlo parts: a sample of the tolerance box through the vectorised evaluator.

Every part is evaluated at once on the crank grid of :mod:`optdesign.tolerance.sampled`
(refined between the samples, then calibrated on the nominal design's exact figures), so
10⁴ parts of a six-phase four-bar take about a second and a half. The figures are those of the
exact evaluator to about 1e-7 in δ (``tests/tolerance`` checks parts against it).
"""
from __future__ import annotations

import time
from typing import Mapping

import numpy as np

from optdesign.quantities.bounds import side_key
from optdesign.quantities.criteria import quantity_specs
from optdesign.tolerance.exact_part import exact_part
from optdesign.tolerance.parts import box_of, draw_offsets
from optdesign.tolerance.sampled import calibrated, grid_size, sampled_parts
from optdesign.tolerance.section import DEFAULT_K, DEFAULT_SAMPLES

#: the percentiles the summary reports
PERCENTILES = (1, 5, 50, 95, 99)
#: the parts' column of each quantity their figures give (:func:`summary`'s bounds)
SAMPLED = {"ratio": "ratio", "ripple": "delta", "transmission_angle": "mu_min_deg"}


def monte_carlo(problem, lengths: Mapping[str, float] | None = None, tolerances=None,
                samples: int | None = None, seed: int | None = None):
    """One row per part: ``<length>_offset_mm`` for every length of the mechanism (the part's
    deviation from ``lengths``), ``delta`` (worst over the listed eccentricities, as the
    solve's objective defines it), ``ratio`` (e = 1), ``mu_min_deg`` (least transmission
    angle) and ``assembles`` (δ, the ratio and μ are NaN for a part that does not).

    ``tolerances``: the problem's ``tolerances:`` section by default, or another
    :class:`~optdesign.tolerance.section.ToleranceSection`, or ``{length: ± mm}`` (uniform).
    ``samples`` and ``seed`` default to the section's. The frame's ``attrs`` hold the
    nominal design's exact figures (``nominal``), the grid (``crank_samples``), the ``seed``
    and the wall time (``wall_time_s``).
    """
    import pandas as pd

    if tolerances is None:
        tolerances = problem.require_section("tolerances")
    box = box_of(problem, lengths, tolerances)
    samples = samples if samples is not None else getattr(tolerances, "samples",
                                                         DEFAULT_SAMPLES)
    seed = seed if seed is not None else getattr(tolerances, "seed", 0)
    started = time.perf_counter()
    offsets = draw_offsets(box, int(samples), getattr(tolerances, "distribution", "uniform"),
                           getattr(tolerances, "k", DEFAULT_K), seed)
    figures, nominal = evaluate_offsets(problem, box, offsets)
    frame = pd.DataFrame({f"{k}_offset_mm": offsets[:, i] for i, k in enumerate(box.names)})
    for key in ("delta", "ratio", "mu_min_deg", "assembles"):
        frame[key] = figures[key]
    frame.attrs.update(nominal=nominal, crank_samples=figures["crank_samples"], seed=seed,
                       wall_time_s=time.perf_counter() - started)
    return frame


def evaluate_offsets(problem, box, offsets: np.ndarray, nominal: dict | None = None,
                     memo: dict | None = None):
    """(figures of every part, the nominal's exact figures): the vectorised evaluation of
    the parts ``box.nominal + offsets``, calibrated on the nominal design. ``memo``: a dict
    kept by a caller that evaluates the same box again, where the nominal's samples (the
    calibration's reference) are kept after the first call."""
    count = int(round(box.values[problem.model.count_variable]))
    nominal = nominal or exact_part(problem, box.values)
    N = grid_size(problem, count)
    raw = sampled_parts(problem, count, box.nominal + offsets, N)
    memo = {} if memo is None else memo
    if "nominal_sampled" not in memo:
        memo["nominal_sampled"] = sampled_parts(problem, count, box.nominal[None, :], N)
    base = memo["nominal_sampled"]
    fixed = calibrated(raw, base, nominal)
    return {"delta": fixed["delta"], "ratio": fixed["ratio"],
            "mu_min_deg": fixed["mu_min_deg"], "assembles": fixed["assembles"],
            "crank_samples": N}, nominal


def summary(frame, problem) -> dict:
    """Percentiles, extremes and the shares of parts that fail the problem's rules: each
    rule's (not assembling, below the angle, the ratio's floor, δ's cap, each side of a
    bound on a quantity the parts' figures give), ``share_rejected`` (not assembling or
    below the angle), ``share_failing_any`` (any of them), and the bounds the parts'
    figures do not give (``bounds_not_sampled``)."""
    ok = frame["assembles"].to_numpy()
    n = len(frame)
    out = {"parts": n, "share_not_assembling": float(1 - ok.mean()) if n else 0.0}
    for key in ("delta", "ratio", "mu_min_deg"):
        v = frame[key].to_numpy()[ok]
        if not v.size:
            out[key] = None
            continue
        out[key] = {"mean": float(v.mean()), "std": float(v.std()), "min": float(v.min()),
                    "max": float(v.max()),
                    **{f"p{p}": float(np.percentile(v, p)) for p in PERCENTILES}}
    c = problem.constraints
    mu = frame["mu_min_deg"].to_numpy()
    below_angle = ok & (mu < c.min_transmission_angle_deg)
    out["min_transmission_angle_deg"] = c.min_transmission_angle_deg
    out["share_below_min_transmission_angle"] = float(below_angle.mean()) if n else 0.0
    out["share_rejected"] = float((~ok | below_angle).mean()) if n else 0.0
    fails = ~ok | below_angle
    if c.min_ratio > 0:
        below_ratio = ok & (frame["ratio"].to_numpy() < c.min_ratio)
        out["min_ratio"] = c.min_ratio
        out["share_below_min_ratio"] = float(below_ratio.mean())
        fails |= below_ratio
    if c.max_ripple is not None:
        above_ripple = ok & (frame["delta"].to_numpy() > c.max_ripple)
        out["max_ripple"] = c.max_ripple
        out["share_above_max_ripple"] = float(above_ripple.mean())
        fails |= above_ripple
    outside, not_sampled = _bounds_outside(frame, problem, ok)
    for share in outside.values():
        fails |= share
    out["share_outside_bounds"] = {key: float(share.mean()) if n else 0.0
                                   for key, share in outside.items()}
    out["bounds_not_sampled"] = not_sampled
    out["share_failing_any"] = float(fails.mean()) if n else 0.0
    return out


def _bounds_outside(frame, problem, ok: np.ndarray) -> tuple[dict, list[str]]:
    """({file key: whether each part lies beyond that side}, [file keys not sampled]) of
    every side of the problem's bounds on quantities (``constraints.NAME``) that the parts'
    figures give: the ratio at e = 1, δ and the least transmission angle (at the problem's
    own eccentricities); the others (a housing radius, a swing, a bound at an eccentricity
    of its own) are not in the parts' figures."""
    outside, not_sampled = {}, []
    for spec in quantity_specs(problem):
        column = SAMPLED.get(spec.name) if spec.at is None else None
        for side in ("lower", "upper"):
            bound = getattr(spec, side)
            if not np.isfinite(bound):
                continue
            key = side_key(problem.constraints.spelled, spec, side)
            if column is None:
                not_sampled.append(key)
                continue
            v = frame[column].to_numpy()
            outside[key] = ok & ((v < bound) if side == "lower" else (v > bound))
    return outside, not_sampled

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

from optdesign.tolerance.exact_part import exact_part
from optdesign.tolerance.parts import box_of, draw_offsets
from optdesign.tolerance.sampled import calibrated, grid_size, sampled_parts
from optdesign.tolerance.section import DEFAULT_K, DEFAULT_SAMPLES

#: the percentiles the summary reports
PERCENTILES = (1, 5, 50, 95, 99)


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
    """Percentiles, extremes and the shares of parts that fail the problem's rules."""
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
    if c.min_ratio > 0:
        out["min_ratio"] = c.min_ratio
        out["share_below_min_ratio"] = float((ok & (frame["ratio"].to_numpy() <
                                                    c.min_ratio)).mean())
    if c.max_ripple is not None:
        out["max_ripple"] = c.max_ripple
        out["share_above_max_ripple"] = float((ok & (frame["delta"].to_numpy() >
                                                     c.max_ripple)).mean())
    return out

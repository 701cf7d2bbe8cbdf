"""A nominal design and its tolerance box; parts drawn from it.

A *part* is the nominal design with every length moved by an offset within ± its tolerance
(the phase count and the options unchanged). Offsets are in mm, one column per length of the
mechanism in its parameter order.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from optdesign.errors import ProblemError


@dataclass(frozen=True)
class Box:
    """The nominal design (``values``: every design key) and ± mm of each of its lengths."""

    names: tuple[str, ...]          # the mechanism's lengths, in its parameter order
    nominal: np.ndarray             # mm, per name
    band: np.ndarray                # ± mm, per name (0: made exactly)
    values: Mapping[str, float]     # the nominal design, every key (the count included)

    @property
    def toleranced(self) -> np.ndarray:
        """Indices of the lengths with a tolerance (the box's dimensions)."""
        return np.flatnonzero(self.band > 0)

    def part(self, offsets) -> dict[str, float]:
        """The design of one part: the nominal values with the lengths moved by ``offsets``."""
        lengths = self.nominal + np.asarray(offsets, dtype=float)
        return dict(self.values) | {k: float(v) for k, v in zip(self.names, lengths)}

    def deviation(self, offsets) -> dict[str, float]:
        return {k: float(v) for k, v in zip(self.names, np.asarray(offsets, dtype=float))}


def box_of(problem, lengths: Mapping[str, float] | None, tolerances) -> Box:
    """The box around ``lengths`` (design keys; missing ones at the problem's fixed and initial
    values) with ``tolerances``: a :class:`~optdesign.tolerance.section.ToleranceSection`,
    or a mapping ``{length: ± mm}`` (lengths it does not name have none)."""
    mech = problem.model
    values = problem.start_values() | {k: float(v) for k, v in (lengths or {}).items()}
    unknown = set(values) - set(problem.design)
    if unknown:
        raise ProblemError(f"{problem.source}: {', '.join(sorted(unknown))} not a design key "
                           f"of {problem.mechanism}")
    count = mech.count_variable
    if (lengths is None or count not in lengths) and problem.count_variable.is_free \
            and len(problem.counts()) > 1:
        raise ProblemError(f"{problem.source}: design.{count} is free: give the design's "
                           f"{count} (e.g. a solved design's)")
    if hasattr(tolerances, "band"):
        band = tolerances.band(problem.mechanism)
    else:
        wrong = set(tolerances) - set(mech.lengths)
        if wrong:
            raise ProblemError(f"{problem.source}: tolerances of {', '.join(sorted(wrong))}: "
                               f"not lengths of {problem.mechanism}")
        band = {k: float(tolerances.get(k, 0.0)) for k in mech.lengths}
    names = tuple(mech.lengths)
    nominal = np.array([values[k] for k in names], dtype=float)
    width = np.array([band[k] for k in names], dtype=float)
    if np.any(width < 0) or np.any(width >= nominal):
        k = names[int(np.argmax((width < 0) | (width >= nominal)))]
        raise ProblemError(f"{problem.source}: the tolerance of {k} ({band[k]:g} mm) must lie "
                           f"in [0, {values[k]:g}) mm, below the length itself")
    return Box(names, nominal, width, values)


def draw_offsets(box: Box, samples: int, distribution: str = "uniform", k: float = 3.0,
                 seed: int | None = 0) -> np.ndarray:
    """``samples`` × lengths offsets, mm: uniform over ± the tolerance, or normal with
    σ = tolerance / k cut at ± the tolerance (a part beyond it is rejected at inspection, so
    every part lies in the box the worst case searches)."""
    rng = np.random.default_rng(seed)
    if distribution == "uniform":
        unit = rng.uniform(-1.0, 1.0, size=(samples, box.band.size))
    elif distribution == "normal":
        from scipy.stats import truncnorm
        unit = truncnorm.rvs(-k, k, size=(samples, box.band.size), random_state=rng) / k
    else:
        raise ValueError(f"unknown distribution {distribution!r}")
    return unit * box.band

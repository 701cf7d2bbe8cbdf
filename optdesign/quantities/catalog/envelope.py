"""The output envelope's quantities: ``ratio``, ``ripple``, ``peak_speed`` and
``transmission_angle``, read off the exact evaluation (:mod:`optdesign.envelope.exact`: the envelope's
extremes at crossings and stationary points, the mean by exact angle increments; the
transmission angle refined between samples). Their NLP forms are the envelope's own
(:mod:`optdesign.solver.nlp`): the hand-over slots, the peak points and the tracked cos μ.
"""
from __future__ import annotations

import math

from optdesign.quantities.base import Quantity


class StrokeFigure(Quantity):
    """A figure of the problem's stroke (:class:`~optdesign.envelope.sampled.StrokeFigures`) at one
    eccentricity of the evaluation."""

    def read(self, figures, ripple: str) -> float:
        raise NotImplementedError

    def exact(self, evaluation, eccentricity, ripple="midrange"):
        return self.read(evaluation.at(eccentricity).figures[evaluation.stroke], ripple)


class Ratio(StrokeFigure):
    name = "ratio"
    unit = "-"
    label = "ratio ω_out/ω1"
    meaning = ("time-mean output speed over the input speed at e = 1 (the gear ratio "
               "i = 1/ratio)")
    worst = "min"
    at = 1.0

    def read(self, figures, ripple):
        return figures.ratio

    def nlp_needs(self, lower, upper):
        """The NLP's mean sums the driving curve's angle increments between hand-over angles
        that are free inside their troughs' windows: any wrong boundary selects a lower curve,
        so it never over-states the mean (safe for a floor). Under a cap it would be pushed
        below the true mean; the hand-over angles are then held at the curves' crossings,
        where the sum is the exact mean (Sharkov & Kalinin 2022, eq. 8: ω_out = max_k ω_k)."""
        return frozenset({"exact_handovers"}) if math.isfinite(upper) else frozenset()


class Ripple(StrokeFigure):
    name = "ripple"
    unit = "-"
    label = "ripple δ"
    meaning = "speed ripple δ of the output (objective.ripple: midrange or mean)"
    worst = "max"

    def read(self, figures, ripple):
        return figures.ripple(ripple)


class PeakSpeed(StrokeFigure):
    name = "peak_speed"
    unit = "rad/s"
    label = "peak output speed ω_max (rad/s)"
    meaning = "largest output speed over the turn"
    worst = "max"

    def read(self, figures, ripple):
        return figures.omega_max


class TransmissionAngle(Quantity):
    name = "transmission_angle"
    unit = "deg"
    label = "least transmission angle μ (deg)"
    meaning = "least transmission angle min(μ, 180° − μ) of every chain over the turn"
    worst = "min"

    def exact(self, evaluation, eccentricity, ripple="midrange"):
        return evaluation.at(eccentricity).min_angle_deg

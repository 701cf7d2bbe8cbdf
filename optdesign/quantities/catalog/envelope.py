"""The output envelope's quantities: ``ratio``, ``ripple``, ``peak_speed`` and
``transmission_angle``, read off the exact evaluation (:mod:`optdesign.envelope.exact`: the
envelope's extremes at crossings and stationary points, the mean by exact angle increments;
the transmission angle refined between samples).

Their NLP forms are the envelope's own (:mod:`optdesign.solver.nlp`, one
:class:`~optdesign.solver.nlp.EccentricityBlock` per eccentricity): ω_max as an epigraph w_hi
over each curve's exact peak, ω_min as w_lo under the exact troughs at the hand-overs, the
mean as the runs' angle increments between hand-over angles, cos μ at its tracked extremes.
Each is conservative on one side; a bound on the other side reads the figure the design
attains: one curve's peak and one hand-over's trough, picked where the start has its worst,
and the hand-overs held at the curves' crossings (Sharkov & Kalinin 2022, eqs. 5-8: the
output is the fastest rocker, ω_out = max_k ω_k).
"""
from __future__ import annotations

import math

import casadi as ca

from optdesign.quantities.base import Quantity


class StrokeFigure(Quantity):
    """A figure of the problem's stroke (:class:`~optdesign.envelope.sampled.StrokeFigures`)
    at one eccentricity of the evaluation."""

    def read(self, figures, ripple: str) -> float:
        raise NotImplementedError

    def exact(self, evaluation, eccentricity, ripple="midrange"):
        return self.read(evaluation.at(eccentricity).figures[evaluation.stroke], ripple)

    def sampled_value(self, view, eccentricity):
        return view.envelope[eccentricity][self.name]


class Ratio(StrokeFigure):
    name = "ratio"
    unit = "-"
    label = "ratio ω_out/ω1"
    meaning = ("time-mean output speed over the input speed at e = 1 (the gear ratio "
               "i = 1/ratio)")
    worst = "min"
    at = 1.0
    words = "ratio"

    def read(self, figures, ripple):
        return figures.ratio

    def nlp_needs(self, sides):
        """The NLP's mean sums the driving curve's angle increments between hand-over angles
        that are free inside their troughs' windows: any wrong boundary selects a lower curve,
        so it never over-states the mean (safe for a floor, or maximised). Under a cap, or
        minimised, it would be pushed below the true mean; the hand-over angles are then held
        at the curves' crossings, where the sum is the exact mean."""
        return frozenset({"exact_handovers"}) if "upper" in sides else frozenset()

    def figures(self, block, attained=False):
        return [block.mean]


class Ripple(StrokeFigure):
    name = "ripple"
    unit = "-"
    label = "ripple δ"
    meaning = "speed ripple δ of the output (objective.ripple: midrange or mean)"
    worst = "max"
    words = "ripple δ"

    def read(self, figures, ripple):
        return figures.ripple(ripple)

    def nlp_needs(self, sides):
        """A floor on δ (or δ maximised) reads the attained δ: the picked peak, the trough at
        a picked hand-over held at its crossing, and the exact mean."""
        return frozenset({"exact_handovers"}) if "lower" in sides else frozenset()

    def figures(self, block, attained=False):
        """δ_e from w_hi >= ω_max and w_lo <= ω_min (never below the exact δ); attained:
        from one curve's exact peak (<= ω_max) and one hand-over's crossing (>= ω_min)."""
        if not attained:
            return [block.ripple]
        return [block.ripple_of(block.picked_peak(), block.picked_trough())]


class PeakSpeed(StrokeFigure):
    name = "peak_speed"
    unit = "rad/s"
    label = "peak output speed ω_max (rad/s)"
    meaning = "largest output speed over the turn"
    worst = "max"

    def read(self, figures, ripple):
        return figures.omega_max

    def figures(self, block, attained=False):
        """w_hi >= every curve's exact peak; attained: the picked curve's exact peak."""
        w = block.picked_peak() if attained else block.w_hi
        return [w * block.e * block.input_speed]


class TransmissionAngle(Quantity):
    name = "transmission_angle"
    unit = "deg"
    label = "least transmission angle μ (deg)"
    meaning = "least transmission angle min(μ, 180° − μ) of every chain over the turn"
    worst = "min"
    words = "least transmission angle"

    def exact(self, evaluation, eccentricity, ripple="midrange"):
        return evaluation.at(eccentricity).min_angle_deg

    @property
    def figure_worst(self):
        return "max"                 # cos²μ: larger is a smaller angle

    def to_figure(self, value):
        """cos²μ of an angle in degrees (μ in [0°, 90°]: cos² falls as μ grows)."""
        return math.cos(math.radians(min(max(value, 0.0), 90.0))) ** 2

    def figures(self, block, attained=False):
        """cos²μ at each chain's tracked extremes of cos μ (exact stationary points)."""
        return [block.cos_sq] if block.cos_sq.numel() else [ca.MX(0, 1)]

    def sampled_value(self, view, eccentricity):
        return view.envelope[eccentricity][self.name]

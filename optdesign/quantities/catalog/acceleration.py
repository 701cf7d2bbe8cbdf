"""``peak_acceleration``: the inertia load and the freewheels' wear.

The largest |d²θ_k/dt²| of the output members over the turn at a constant crank speed ω1,
rad/s²: d²θ_k/dt² = ω1²·d²θ_k/dφ² (Sharkov & Kalinin 2022, the rocker speeds of eqs. 5-8
differentiated once more), with d²θ_k/dφ² by algorithmic differentiation.
"""
from __future__ import annotations

import numpy as np

from optdesign.quantities.base import TurnQuantity


class PeakAcceleration(TurnQuantity):
    name = "peak_acceleration"
    unit = "rad/s^2"
    label = "peak rocker acceleration (rad/s²)"
    meaning = ("largest |d²θ/dt²| of the output members over the turn at constant ω1 "
               "(inertia loads, freewheel wear)")
    worst = "max"

    def expression(self, model, phi, p, count):
        dd = model["ddtheta"]
        return [dd[k] for k in range(dd.numel())] + [-dd[k] for k in range(dd.numel())]

    def from_kinematics(self, sampled):
        dd = sampled["ddtheta"]
        return np.vstack([dd, -dd])

    def components(self, maxima, input_speed):
        return input_speed ** 2 * maxima       # both signs: the largest is max |d²θ/dt²|

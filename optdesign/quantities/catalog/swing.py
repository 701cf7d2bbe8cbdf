"""``swing``: the freewheels' working angle.

The least swing angle θ_max − θ_min of the output members over a turn, degrees. Each member's
angle is taken relative to its angle at φ = 0 and wrapped to (−π, π], so a member whose
direction crosses ±π swings as it does anywhere else (a rocker swings less than half a turn).
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np

from optdesign.quantities.base import TurnQuantity


class Swing(TurnQuantity):
    name = "swing"
    unit = "deg"
    label = "least swing of the output members (deg)"
    meaning = ("least swing angle θ_max − θ_min of the output members over the turn "
               "(the freewheels' working angle)")
    worst = "min"

    def expression(self, model, phi, p, count):
        out = []
        for theta in model["theta"]:
            moved = theta - ca.substitute(theta, phi, ca.SX(0.0))
            out.append(ca.atan2(ca.sin(moved), ca.cos(moved)))
        return out + [-x for x in out]

    def from_kinematics(self, sampled):
        theta = sampled["theta"]
        moved = theta - theta[:, :1]                     # the grid's first angle is φ = 0
        moved = np.arctan2(np.sin(moved), np.cos(moved))
        return np.vstack([moved, -moved])

    def components(self, maxima, input_speed):
        n = maxima.shape[0] // 2
        return (maxima[:n] + maxima[n:]) * (180.0 / math.pi)   # max θ - min θ per member

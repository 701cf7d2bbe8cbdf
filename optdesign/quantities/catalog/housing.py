"""``housing_radius``: the casing the linkage must clear.

The largest distance of any moving joint from the crank centre O over a turn, mm. Every
mechanism places O at the origin of its frame (its ``joints`` name it ``O``); a joint moves
when its position depends on the crank angle (the fixed pivots lie inside the casing's wall).
"""
from __future__ import annotations

import casadi as ca

from optdesign.quantities.base import TurnQuantity


class HousingRadius(TurnQuantity):
    name = "housing_radius"
    unit = "mm"
    label = "housing radius R (mm)"
    meaning = ("largest distance of any moving joint from the crank centre O over a turn "
               "(the casing the linkage must clear)")
    worst = "max"

    def expression(self, model, phi, p, count):
        joints = model["joints"]
        centre = joints.get("O", ca.SX.zeros(2, 1))
        return [ca.sumsqr(point - centre) for point in joints.values()
                if ca.depends_on(point, phi)]

    def components(self, maxima, input_speed):
        return maxima ** 0.5          # the squared distances' maxima, as distances

"""Planar geometry in CasADi symbols: the circle-circle intersection every joint of a linkage is.

Written with atan2 and the discriminant instead of arccos, whose derivative blows up at ±1
(docs/formulation.md). The assembly branch is an explicit ±1, kept over the whole turn.
"""
from __future__ import annotations

import math

import casadi as ca

#: Floor under the squared half-chord inside ``sqrt``: keeps values and derivatives finite
#: when an optimiser steps outside the assembly region (the constraints then pull it back).
SQRT_FLOOR = 1e-12


def circle_intersection(p, r_p, q, r_q, branch):
    """Point at distance ``r_p`` from ``p`` and ``r_q`` from ``q`` on the side ``branch``.

    Parameters
    ----------
    p, q : casadi 2-vectors
        Centres of the two circles.
    r_p, r_q : scalar expressions
        Their radii.
    branch : +1 or -1
        +1 puts the point on the left of the directed line p → q, -1 on its right.

    Returns
    -------
    point : 2-vector
    cos_angle : scalar
        Cosine of the angle at the intersection point between its two sides (law of cosines),
        the transmission angle when the sides are rod and rocker. ``|cos_angle| <= 1`` is the
        assembly condition; ``1 - cos_angle**2`` is the normalised discriminant.
    """
    d = q - p
    dist2 = ca.dot(d, d)
    dist = ca.sqrt(dist2)
    along = (r_p**2 - r_q**2 + dist2) / (2 * dist)
    half_chord2 = r_p**2 - along**2
    half_chord = ca.sqrt(ca.fmax(half_chord2, SQRT_FLOOR * r_p**2))
    ex = d / dist
    ey = ca.vertcat(-ex[1], ex[0])
    point = p + along * ex + branch * half_chord * ey
    cos_angle = (r_p**2 + r_q**2 - dist2) / (2 * r_p * r_q)
    return point, cos_angle


def angle_of(vector):
    """Direction of a 2-vector, atan2(y, x)."""
    return ca.atan2(vector[1], vector[0])


def unit(angle):
    """The unit vector (cos angle, sin angle)."""
    return ca.vertcat(ca.cos(angle), ca.sin(angle))


def direction(vector):
    """The unit vector along a 2-vector: (cos α, sin α) of its direction α = atan2(y, x),
    without the angle itself (no atan2, whose SIMD and C-library values differ in the last
    bit on some machines: a function free of it runs on the compiled lanes,
    :mod:`optdesign.numerics.native_lanes`)."""
    return vector / ca.sqrt(ca.dot(vector, vector))


def rotated(vector, angle: float):
    """A 2-vector turned by a fixed ``angle`` (a number): (x cos a − y sin a, x sin a + y cos a);
    ``rotated(direction(v), a)`` is ``unit(angle_of(v) + a)``."""
    c, s = math.cos(angle), math.sin(angle)
    return ca.vertcat(c * vector[0] - s * vector[1], s * vector[0] + c * vector[1])

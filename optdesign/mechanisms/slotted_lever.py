"""Vergov's lever-tooth pulse variator using the reverse stroke (Vergov, TU Sofia; docs/papers.md).

The oscillation generator is a symmetric slotted-lever (cross-slider) mechanism, links 1-7 of
the paper's Fig. 2: stand 1 at O, the movable (variator) stand 2 at distance ``L`` from O on the
x-axis, kulisa 3 turning with the input angle φ, cross slider 4 whose centre A (hinge 5) stays
at the foot of the perpendicular from stand 2 on the line of kulisa 3, eqs. (1)-(5):

    OA = L·cos φ,   XA = L·cos² φ,   YA = L·sin φ·cos φ,

so A runs twice per input turn round the circle of diameter L through O and stand 2. Slider 6
at A drives the kulisa-crank 7 about D = (XD, 0); its angle, eq. (7):

    ψ(φ) = atan(L·sin φ·cos φ / (XD - L·cos² φ)),

with the analogue of its angular speed Aω7 = dψ/dφ (eq. 8), ω7 = ω1·Aω7 (eq. 10), the
instantaneous ratio i(φ) = ω7/ω1 (eq. 11) and the acceleration analogue d²ψ/dφ². Link 7 drives
the freewheel through the four-bar 7-8-9-10, whose sizes the paper does not give; like the paper
we take the freewheel to turn with link 7. Two freewheels of opposite engagement on two output
shafts joined by equal gears 11 let the reverse stroke drive the output too: stroke ``both``.

Sections. The paper analyses one "section" of a variator built of several. ψ has period π in φ
(A circles twice per turn), so n sections are phase-shifted by π/n of the input angle, one n-th
of the generator's cycle: shifting by 2π/n would put two sections exactly in phase.

Closed forms (tests): ψ oscillates between ±asin(L/(2·XD - L)) twice per turn, and
dψ/dφ = L/(XD - L) at φ = 0 (A nearest D), -L/XD at φ = π/2 (A at O).

Transmission angle: 90° everywhere (``cos_mu`` = 0). Without friction the slider presses on
the slot of link 7 normal to the slot, which is also the direction of motion of link 7's point
under the slider: the pressure angle of a slotted lever is zero. The paper states no other.
"""
from __future__ import annotations

import math

import casadi as ca

from optdesign.errors import ProblemError
from optdesign.mechanisms.base import Mechanism, VariableSpec
from optdesign.quantities.criteria import LengthConstraint


class SlottedLever(Mechanism):
    name = "slotted_lever"
    source = ("Vergov A. Kinematic analysis of the pulse lever-tooth variator using reverse "
              "stroke. TU Sofia, Plovdiv branch (internal grant 2017; our copy names no "
              "venue) (docs/papers.md)")
    variables = (
        VariableSpec("XD", "mm", "distance from stand 1 (O) to the pivot D of the kulisa-crank 7"),
        VariableSpec("L", "mm", "distance between the centres of stands 1 and 2 (regulated)"),
        VariableSpec("sections", "-", "number n of sections, phase-shifted by π/n of the input "
                                      "angle (paper: 1)", integer=True, minimum=1),
    )
    count_variable = "sections"
    #: the design ``optdesign init`` starts from: it assembles over the whole turn, its
    #: length to optimise freed over a range that holds it (the paper's design, the range of
    #: problems/vergov_solve.yaml)
    starter = {"input_speed": 0.628,
               "design": {"XD": {"lower": 120, "upper": 600, "initial": 292}, "L": 74,
                          "sections": 3}}
    regulating_variable = "L"
    strokes = ("forward", "reverse", "both")

    def chain_expressions(self, phi, p, count, options):
        """ψ of every section, eqs. (4), (5) and (7).

        Written with atan2(YA, XD - XA), which is eq. (7)'s atan while XD > L (the design
        constraint) and keeps its derivatives finite should an optimiser step past it.
        """
        xd, big_l = p["XD"], p["L"]
        theta, cos_mu = [], []
        joints = {"O": ca.vertcat(0, 0), "S2": ca.vertcat(big_l, 0), "D": ca.vertcat(xd, 0)}
        links = []
        for k in range(1, count + 1):
            phi_k = phi - (k - 1) * math.pi / count
            xa = big_l * ca.cos(phi_k) ** 2                               # eq. (4)
            ya = big_l * ca.sin(phi_k) * ca.cos(phi_k)                    # eq. (5)
            theta.append(ca.atan2(ya, xd - xa))                           # eq. (7)
            cos_mu.append(ca.SX(0))
            joints[f"A{k}"] = ca.vertcat(xa, ya)
            links += [("O", f"A{k}"), ("S2", f"A{k}"), ("D", f"A{k}")]
        return {"theta": theta, "cos_mu": cos_mu, "joints": joints, "links": links}

    def criteria(self, constraints, options):
        """Link 7 oscillates only while its pivot D lies beyond A's circle, XD > L:
        1 - L/XD >= assembly_margin (dimensionless, O(1) for the NLP)."""
        return [LengthConstraint("pivot_outside_circle", lambda p: 1 - p["L"] / p["XD"],
                                 lower=constraints.assembly_margin, unit="-",
                                 file_key="design.L (below design.XD)")]

    def check_values(self, values, count):
        if values["XD"] <= values["L"]:
            raise ProblemError(f"design.XD must exceed L (got XD = {values['XD']:g}, "
                               f"L = {values['L']:g}): the kulisa-crank 7 would turn round "
                               f"instead of oscillating (eq. 7 needs XD > L)")


def paper_speed_analogue(phi, xd, big_l):
    """Aω7 = dψ/dφ exactly as printed in the paper's eq. (8) (numpy or floats)."""
    import numpy as np

    s, c = np.sin(phi), np.cos(phi)
    den = xd - big_l * c**2
    num = big_l * c**2 / den - 2 * big_l**2 * s**2 * c**2 / den**2 - big_l * s**2 / den
    return num / (big_l**2 * s**2 * c**2 / den**2 + 1)

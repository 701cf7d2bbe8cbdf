"""The compact pulse reducer of Ambartsumyants & Subbotina 2015, eqs. (1)-(2) (docs/papers.md).

A crank O A (``r1``) drives a slotted link; the crank pin's distance to the slot's pivot P (at
the centre distance ``a`` from O) moves a toothed rack along the slot, and the rack turns the
driving holder of a freewheel through a pinion of pitch radius ``R1``. The paper's reducer has
two such rack drives whose freewheels share the output shaft, "one per half-turn": its position
function of the converting mechanism, eqs. (1)-(2), with relative sizes r = r1/a, R = R1/a:

    Φ = (r - 1 + √(1 - 2r·cos φ + r²))/R                       0 <= φ <= π     (1)
    Φ = 2r/R + (r - 1 + √(1 + 2r·cos φ + r²))/R                π <= φ <= 2π    (2)

(the OCR prints the roots as √((1 ∓ r·cos φ)² + r²·sin² φ), which expand to the above).

Output members. Φ is the angle of the *driven* holder; the generic envelope needs the angles
of the *driving* holders, one per freewheel. Rack drive k, its pivot P_k at angle α_k from O,
turns its holder by the change of |P_k A| over R1:

    θ_k(φ) = (r - 1 + √(1 - 2r·cos(φ - α_k) + r²))/R,   α_k = 2π(k - 1)/n,

smooth and periodic. For the paper's n = 2 (α = 0, π) the envelope max(0, θ_1', θ_2') is
θ_1' on [0, π] and θ_2' on [π, 2π], whose integral is eqs. (1)-(2) exactly: the second branch's
"1 + 2r·cos φ" is the distance to the pivot opposite the first. The count generalises as n rack
drives with pivots evenly spaced round the crank, like the rocker pivots of the four-bar
converter; n = 1 is the intermittent drive (output at rest for half a turn).

Closed forms (tests): each drive advances its holder by 2r/R per turn, so with n = 2 the output
advances 4r/R per turn and the ratio is 4·r1/(2π·R1); the largest holder speed is r/R = r1/R1 at
cos φ = r; with n = 2 the output stops at the dead centres φ = 0, π. For any n >= 2 the exact
figures equal those of the sine limit a → ∞, θ_k' = (r1/R1)·sin(φ - α_k): ω_max/ω1 = r1/R1,
ω_min/ω1 = (r1/R1)·cos(π/n), ratio (r1/R1)·n·sin(π/n)/π, at every a we tried (observed to
rounding, not derived): ``a`` shapes the curves but not the figures.
"""
from __future__ import annotations

import math

import casadi as ca

from optdesign.errors import ProblemError
from optdesign.mechanisms.base import Mechanism, VariableSpec
from optdesign.mechanisms.geometry import SQRT_FLOOR, unit
from optdesign.quantities.criteria import LengthConstraint

TWO_PI = 2 * math.pi


class PulseReducer(Mechanism):
    name = "pulse_reducer"
    source = ("Ambartsumyants R.V., Subbotina M.I. Researching the links' motion dynamics "
              "of new compact pulse reducer design. Pratsi Odeskoho politekhnichnoho "
              "universytetu, 2015, no. 2(46), p. 57 ff. (docs/papers.md)")
    variables = (
        VariableSpec("r1", "mm", "crank radius r1 (regulated)"),
        VariableSpec("a", "mm", "centre distance a from the crank axis to each slot pivot"),
        VariableSpec("R1", "mm", "pitch radius R1 of the pinion on each freewheel's driving "
                                 "holder"),
        VariableSpec("freewheels", "-", "number n of rack drives and freewheels (paper: 2, one "
                                        "per half-turn); pivots at 2π(k-1)/n", integer=True,
                     minimum=1),
    )
    count_variable = "freewheels"
    #: the design ``optdesign init`` starts from: it assembles over the whole turn, its
    #: length to optimise freed over a range that holds it (the paper's design, the range of
    #: problems/pulse_reducer_solve.yaml)
    starter = {"input_speed": 97.0,
               "design": {"r1": {"lower": 2, "upper": 40, "initial": 5}, "a": 50, "R1": 250,
                          "freewheels": 3}}
    regulating_variable = "r1"
    strokes = ("forward",)

    def chain_expressions(self, phi, p, count, options):
        """Driving-holder angles θ_k, eq. (1) with φ shifted to each drive's pivot angle.

        ``cos_mu`` is 0 (μ = 90°): the paper states no transmission angle for the rack drive and
        none fits the generic rule: the drive has dead centres twice per turn by design, where
        the rack stops. Its assembly condition, r < 1, is a design constraint instead.
        """
        r1, a, big_r = p["r1"], p["a"], p["R1"]
        pin = r1 * unit(phi)
        theta, cos_mu = [], []
        joints = {"O": ca.vertcat(0, 0), "A": pin}
        links = [("O", "A")]
        for k in range(1, count + 1):
            alpha = (k - 1) * TWO_PI / count
            dist2 = a**2 - 2 * a * r1 * ca.cos(phi - alpha) + r1**2        # |P_k A|²
            dist = ca.sqrt(ca.fmax(dist2, SQRT_FLOOR * a**2))
            theta.append((r1 - a + dist) / big_r)                        # eq. (1), in mm
            cos_mu.append(ca.SX(0))
            joints[f"P{k}"] = a * unit(alpha)
            links.append(("A", f"P{k}"))
        return {"theta": theta, "cos_mu": cos_mu, "joints": joints, "links": links}

    def criteria(self, constraints, options):
        """The crank pin stays inside the pivot circle, r = r1/a < 1 (eqs. 1-2):
        1 - r1/a >= assembly_margin (dimensionless, O(1) for the NLP)."""
        return [LengthConstraint("crank_inside_pivots", lambda p: 1 - p["r1"] / p["a"],
                                 lower=constraints.assembly_margin, unit="-",
                                 file_key="design.r1 (below design.a)")]

    def check_values(self, values, count):
        if values["r1"] >= values["a"]:
            raise ProblemError(f"design.r1 must be shorter than a (got r1 = {values['r1']:g}, "
                               f"a = {values['a']:g}): eqs. (1)-(2) need r = r1/a < 1, or the "
                               f"crank pin passes over the slot pivot")

    def breakpoints(self, values, count):
        """Dead centres φ = α_k and α_k + π of every drive, where its rack reverses.

        With n = 2 these are the paper's switch points 0 and π, where the output stops and the
        output's Φ'' jumps (from -r/(R(1+r)) to r/(R(1-r)) at π).
        """
        alphas = [k * TWO_PI / count for k in range(count)]
        return tuple(sorted({round(x % TWO_PI, 15) for al in alphas for x in (al, al + math.pi)}))


def paper_position(phi, r, big_r):
    """Φ(φ) of eqs. (1)-(2) for the paper's two freewheels, any real φ (casadi or float).

    Relative sizes r = r1/a, R = R1/a. Written with ``if_else`` on φ mod 2π, so algorithmic
    differentiation gives the one-sided derivatives Φ', Φ'' of the branch in force (at φ = π
    exactly: the first branch); each full turn adds 4r/R.
    """
    turns = ca.floor(phi / TWO_PI)
    phi0 = phi - TWO_PI * turns
    first = (r - 1 + ca.sqrt(1 - 2 * r * ca.cos(phi0) + r**2)) / big_r            # eq. (1)
    second = 2 * r / big_r + (r - 1 + ca.sqrt(1 + 2 * r * ca.cos(phi0) + r**2)) / big_r  # (2)
    return turns * 4 * r / big_r + ca.if_else(phi0 <= math.pi, first, second)


def position_function() -> ca.Function:
    """``casadi.Function`` (phi, r1, a, R1) -> (Phi, dPhi, ddPhi): eqs. (1)-(2) and the analogues
    of angular speed and acceleration Φ' = dΦ/dφ, Φ'' = d²Φ/dφ² (one-sided at φ = kπ).

    For the dynamic model of the paper (eq. 3), which needs Φ, Φ', Φ'' along the motion.
    """
    phi, r1, a, big_r = (ca.SX.sym(s) for s in ("phi", "r1", "a", "R1"))
    big_phi = paper_position(phi, r1 / a, big_r / a)
    d1 = ca.jacobian(big_phi, phi)
    d2 = ca.jacobian(d1, phi)
    return ca.Function("pulse_reducer_Phi", [phi, r1, a, big_r], [big_phi, d1, d2],
                       ["phi", "r1", "a", "R1"], ["Phi", "dPhi", "ddPhi"])

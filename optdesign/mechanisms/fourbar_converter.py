"""The n-phase four-bar converter of Sharkov & Kalinin 2022, eqs. (1)-(4) (docs/papers.md).

Crank OA (l1, angle φ1) turns about O. The main coupler is a disc hinged at A; its arm AB1 (l2)
drives rocker O1B1 (l3) about O1 = (l0, 0). Rocker pivots O_i sit at radius l0, angle (i-1)τ,
τ = 2π/n. Pins C_i on the disc sit at angle (i-1)τ + φ2 (φ2 = direction of AB1, eq. 4);
rods C_iB_i (l2') drive rockers O_iB_i (l3).

Pin layout. The paper's eq. (2) puts C_i at radius l2' from A, but its table is reproduced only
when |AC_i| = l2 - l2' (A, C1, B1 collinear, so every rod C_iB_i is l2' long, C1B1 included):
``pin_layout: collinear`` (default). ``pin_layout: text`` is eq. (2) to the letter.
"""
from __future__ import annotations

import math
from functools import lru_cache

import casadi as ca
import numpy as np

from optdesign.declarations import Key
from optdesign.errors import ProblemError
from optdesign.mechanisms.base import Mechanism, OptionSpec, VariableSpec
from optdesign.mechanisms.geometry import angle_of, circle_intersection, direction, unit
from optdesign.quantities.criteria import LengthConstraint

BRANCH_SIGN = {"left": 1, "right": -1}


class FourBarConverter(Mechanism):
    name = "fourbar_converter"
    source = ("Sharkov O.V., Kalinin A.V. Analytical evaluation of the velocity fluctuation "
              "of pulse continuously variable transmissions. BMSTU Journal of Mechanical "
              "Engineering, 2022, no. 5, pp. 35-42, doi:10.18698/0536-1044-2022-5-35-42 "
              "(docs/papers.md)")
    variables = (
        VariableSpec("l0", "mm", "crank centre O to every rocker pivot O_i"),
        VariableSpec("l1", "mm", "crank OA (the eccentricity; regulated)"),
        VariableSpec("l2", "mm", "main coupler arm AB1"),
        VariableSpec("l2_prime", "mm", "additional rods C_iB_i"),
        VariableSpec("l3", "mm", "rockers O_iB_i"),
        VariableSpec("phases", "-", "phase count n (rockers and freewheels)", integer=True,
                     minimum=2),
    )
    count_variable = "phases"
    #: the design ``optdesign init`` starts from: it assembles over the whole turn, its lengths
    #: to optimise freed over ranges that hold it (the paper's design, ranges of
    #: problems/free_design.yaml)
    starter = {"input_speed": 97.0,
               "design": {"l0": {"lower": 100, "upper": 400, "initial": 225}, "l1": 20,
                          "l2": {"lower": 100, "upper": 400, "initial": 225},
                          "l2_prime": {"lower": 30, "upper": 300, "initial": 100},
                          "l3": {"lower": 20, "upper": 150, "initial": 56}, "phases": 6}}
    regulating_variable = "l1"
    options = (
        OptionSpec("branch", ("left", "right"), "left",
                   "assembly branch: B_i left (paper) or right of the line from the driving "
                   "joint to the rocker pivot; 'right' is the mirror image"),
        OptionSpec("pin_layout", ("collinear", "text"), "collinear",
                   "|AC_i| = l2 - l2' (reproduces the paper's table) or l2' (its eq. 2)"),
    )

    def chain_expressions(self, phi, p, count, options, coupler_angle: bool = True):
        """Joint positions by circle intersections, eqs. (1)-(4) and the O_iC_iB_i triangles.

        The rocker angle θ_k is the direction of O_kB_k (the paper's φ_{2k+1}); its transmission
        angle μ_k is the angle at B_k between rod (coupler) and rocker. The pins C_i lie at
        angle φ2 + (i-1)τ from A, φ2 = atan2 of AB1 (eq. 4); without ``coupler_angle`` the
        unit vector of that angle is AB1's direction turned by (i-1)τ, no atan2 taken
        (:meth:`screening_expressions`).
        """
        l0, l1, l2, l2p, l3 = (p[k] for k in ("l0", "l1", "l2", "l2_prime", "l3"))
        sign = BRANCH_SIGN[options["branch"]]
        pin_radius = l2 - l2p if options["pin_layout"] == "collinear" else l2p
        tau = 2 * math.pi / count
        a = l1 * unit(phi)                                             # eq. (3)
        o1 = ca.vertcat(l0, 0)
        b1, cos_mu1 = circle_intersection(a, l2, o1, l3, sign)         # four-bar O A B1 O1
        if coupler_angle:
            lead = angle_of(b1 - a)                                    # φ2, eq. (4)
        else:                           # (cos φ2, sin φ2), read off the arm AB1 itself
            lead = direction(b1 - a)
        theta = [angle_of(b1 - o1)]
        cos_mu = [cos_mu1]
        joints = {"O": ca.vertcat(0, 0), "A": a, "O1": o1, "B1": b1}
        links = [("O", "A"), ("A", "B1"), ("O1", "B1")]
        rocker = _rocker(coupler_angle, sign)
        for i in range(2, count + 1):
            angle = (i - 1) * tau
            o_i = l0 * unit(angle)
            theta_i, cos_mu_i, c_i, b_i = rocker.call(
                [a, lead, o_i, l3, l2p, pin_radius, angle, math.cos(angle), math.sin(angle)])
            theta.append(theta_i)
            cos_mu.append(cos_mu_i)
            joints |= {f"O{i}": o_i, f"C{i}": c_i, f"B{i}": b_i}
            links += [("A", f"C{i}"), (f"C{i}", f"B{i}"), (f"O{i}", f"B{i}")]
        return {"theta": theta, "cos_mu": cos_mu, "joints": joints, "links": links}

    def screening_expressions(self, phi, p, count, options):
        """:meth:`chain_expressions` without the coupler's angle φ2: the pins' directions
        turned from AB1's own (the same arithmetic up to rounding; the speeds free of atan2,
        whose NumPy SIMD values differ from the C library's on machines with AVX-512, run on
        the compiled lanes there: ``benchmarks/solve_floor.py`` gave the warm screening at
        24 phases 78 ms where it took 172)."""
        return self.chain_expressions(phi, p, count, options, coupler_angle=False)

    constraint_declarations = (
        Key("min_pin_radius", "number", "least pin radius |AC_i| of the disc (l2 − l2_prime, "
            "or l2_prime under pin_layout: text): the pins must fit on the disc", unit="mm",
            default=0.0, lower=0),
        Key("grashof", "bool", "chain 1 (O A B1 O1) a Grashof crank-rocker with l1 the crank",
            default=False),
    )

    def joint_forces(self, joints, torques):
        """Forces in the joints of the converter, the links massless, when rocker k delivers
        ``torques[k]`` to its freewheel (per sample). The rods C_iB_i (i >= 2) are two-force
        members: the force along the rod, f_i, balances rocker i about O_i, f_i =
        -M_i / ((B_i - O_i) x e_i), e_i the rod's unit vector from C_i to B_i; it is the force
        at B_i, C_i and O_i. The disc (A, B_1, C_i) takes the pin force P at B_1 from rocker
        1 (M_1 = (B_1 - O_1) x P) and the rods' forces, and is balanced about A by P; the
        crank pin A carries Q = P - Σ f_i·e_i, as does the crank's pivot O. Lengths in mm are
        turned to m, so forces are in N."""
        pos = {k: np.asarray(v, dtype=float) / 1000.0 for k, v in joints.items()}
        torques = np.atleast_2d(np.asarray(torques, dtype=float))
        count = torques.shape[0]
        out, rods = {}, np.zeros_like(pos["A"])
        moment_of_rods = np.zeros(pos["A"].shape[1])
        for i in range(2, count + 1):
            b, c, o = pos[f"B{i}"], pos[f"C{i}"], pos[f"O{i}"]
            e = (b - c) / np.hypot(*(b - c))
            f = -torques[i - 1] / _cross(b - o, e)
            out[f"B{i}"] = out[f"C{i}"] = out[f"O{i}"] = np.abs(f)
            rods += f * e
            moment_of_rods += _cross(c - pos["A"], f * e)
        r1, r2 = pos["B1"] - pos["O1"], pos["B1"] - pos["A"]
        # [r1 x P, r2 x P] = [M_1, Σ (C_i - A) x f_i e_i]: P from the 2x2 system per sample
        det = r1[0] * r2[1] - r1[1] * r2[0]
        m1, m2 = torques[0], moment_of_rods
        px = (m1 * r2[0] - m2 * r1[0]) / det
        py = (m1 * r2[1] - m2 * r1[1]) / det
        out["B1"] = out["O1"] = np.hypot(px, py)
        out["A"] = out["O"] = np.hypot(px - rods[0], py - rods[1])
        return out

    @staticmethod
    def pin_radius(lengths, options) -> float:
        """|AC_i|: l2 - l2' (collinear layout) or l2' (eq. 2 to the letter)."""
        collinear = options.get("pin_layout", "collinear") == "collinear"
        return lengths["l2"] - lengths["l2_prime"] if collinear else lengths["l2_prime"]

    def criteria(self, constraints, options):
        """The pins must fit on the disc, |AC_i| >= min_pin_radius; with ``grashof: true``
        chain 1 (O A B1 O1) is a Grashof crank-rocker with l1 the crank, s + l <= p + q,
        written as l1 + X <= (sum of the other two) for each X of l0, l2, l3 so that no max()
        is needed (summing two of them also gives l1 <= l0, l2, l3)."""
        own = self.constraint_values(constraints)
        out = [LengthConstraint("pin_radius", lambda p: self.pin_radius(p, options),
                                lower=own["min_pin_radius"], column="pin_radius",
                                meaning="|AC_i|: l2 - l2_prime, or l2_prime under pin_layout: "
                                        "text",
                                at_zero="a pin radius of 0 puts every rod on the crank pin",
                                file_key="constraints.min_pin_radius")]
        if own["grashof"]:
            for k in ("l0", "l2", "l3"):
                out.append(LengthConstraint(
                    f"grashof[{k}]",
                    lambda p, k=k: p["l0"] + p["l2"] + p["l3"] - 2 * p[k] - p["l1"],
                    file_key="constraints.grashof"))
        return out

    def check_values(self, values, count):
        if values["l1"] >= values["l0"]:
            raise ProblemError(f"design.l1 must be shorter than l0 (got l1 = {values['l1']:g}, "
                               f"l0 = {values['l0']:g}): the crank would reach the rocker pivots")


def _cross(a, b):
    """The planar cross product a_x·b_y − a_y·b_x, per sample."""
    return a[0] * b[1] - a[1] * b[0]


@lru_cache(maxsize=4)
def _rocker(coupler_angle: bool, sign: int) -> ca.Function:
    """Rocker i >= 2 of :meth:`FourBarConverter.chain_expressions` as an SX function of (A,
    φ2 or AB1's direction, O_i, l3, l2', the pin radius |AC_i|, the pins' angle (i-1)τ and
    its cosine and sine) -> (θ_i, cos μ_i, C_i, B_i): pin C_i at angle φ2 + (i-1)τ from A
    (eq. 4), B_i where rod C_iB_i meets rocker O_iB_i. Each rocker is this function called on
    the chain's symbols: the nodes CasADi makes are those the same arithmetic written out
    per rocker makes (the kinematics serialise to the same text), made in one call instead
    of a few hundred Python operations each."""
    a = ca.SX.sym("a", 2)
    o_i = ca.SX.sym("o_i", 2)
    l3, l2p, pin_radius, angle, cos_a, sin_a = (
        ca.SX.sym(name) for name in ("l3", "l2p", "pin_radius", "angle", "cos_a", "sin_a"))
    if coupler_angle:
        lead = ca.SX.sym("phi2")
        towards = unit(angle + lead)
    else:       # geometry.rotated(u2, angle), the angle's cosine and sine given
        lead = ca.SX.sym("u2", 2)
        towards = ca.vertcat(cos_a * lead[0] - sin_a * lead[1],
                             sin_a * lead[0] + cos_a * lead[1])
    c_i = a + pin_radius * towards                                     # eq. (4)
    # B_i on the same side of C_i -> O_i as B1 of A -> O1: the branch is kept.
    b_i, cos_mu_i = circle_intersection(o_i, l3, c_i, l2p, -sign)
    return ca.Function("rocker", [a, lead, o_i, l3, l2p, pin_radius, angle, cos_a, sin_a],
                       [angle_of(b_i - o_i), cos_mu_i, c_i, b_i])

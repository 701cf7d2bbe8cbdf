"""Imbalance of a flexible (non-rigid) cardan shaft: the paper's eqs. 6-18, in SI units.

Source: Vestnik DGTU 2017, no. 2(89), pp. 23-30 (citation and readings: docs/papers.md,
section 4). The shaft is a uniform tube simply supported at its two joints, a
distance l apart (assumption 3 of the paper), of mass m = m'·l. Its axis is initially bent
along the first bending mode with a mid-span deflection y0_max (eq. 11); correction planes 1-1
and 2-2 lie at A and C from supports I and II.

Units: every function takes and returns SI (m, kg, s, N·m², kg·m for an imbalance). The
section converts to the contract's units (mm, g·mm). Speeds are angular, in rad/s, and must
stay below the first critical speed ω_cr: there the model's deflection is infinite, so every
function raises a :class:`ProblemError` at or above it instead of returning an infinite or
negative value.

Imbalances are returned as magnitudes. In the paper D0 points along the initial bend and the
correcting imbalances Dk1, Dk2 point the other way (their minus signs in eqs. 8, 10, 16).

Where the OCR of the paper is garbled, the formula was derived again (first mode, Euler-
Bernoulli beam) and the derivation is written in the docstring: eq. 12's β (a garbled
fraction), and the leading factor of eq. 17 (OCR "i", which is 5).
"""
from __future__ import annotations

import numpy as np

from optdesign.errors import ProblemError

#: GOST 5005-82: the limiting deviation from straightness of a cardan-shaft tube on any
#: 1 m of its length, mm per metre, by accuracy class (the paper, before eq. 11).
GOST_5005_STRAIGHTNESS_MM_PER_M = {"normal": 0.4, "increased": 0.25, "high": 0.15}

#: D0 = (5/8)·m·y_max: the principal imbalance of a uniform cylinder bent along its first
#: mode (eq. 6, taken by the paper from its ref. [8]).
PRINCIPAL_IMBALANCE_FACTOR = 5.0 / 8.0


def tube_section(outer_diameter: float, wall: float) -> tuple[float, float]:
    """Area (m²) and second moment of area (m⁴) of a round tube.

    A = π/4·(D² - d²), I = π/64·(D⁴ - d⁴), d = D - 2·wall (the paper's I of assumption 3).
    """
    inner = outer_diameter - 2.0 * wall
    area = np.pi / 4.0 * (outer_diameter**2 - inner**2)
    second_moment = np.pi / 64.0 * (outer_diameter**4 - inner**4)
    return float(area), float(second_moment)


def first_critical_speed(length: float, EI: float, mass_per_length: float) -> float:
    """First critical speed of a uniform simply supported shaft, rad/s (eq. 13).

    ω_cr = (π/l)²·sqrt(EI/m'): the first bending eigenfrequency of a pinned-pinned
    Euler-Bernoulli beam, whose mode is sin(πx/l). Units: (1/m²)·sqrt(N·m²/(kg/m)) =
    (1/m²)·sqrt(m⁴/s²) = 1/s.
    """
    return float((np.pi / length) ** 2 * np.sqrt(EI / mass_per_length))


def beta(omega_cr: float) -> float:
    """β = 1/ω_cr², s² (eq. 13).

    Eq. 12 is garbled in the OCR; for the first mode of a uniform pinned-pinned shaft it reads
    β = m·l³/(π⁴·EI) = m'·l⁴/(π⁴·EI), which is 1/ω_cr² with ω_cr of
    :func:`first_critical_speed`.
    """
    return 1.0 / omega_cr**2


def initial_deflection(length: float, mm_per_metre: float) -> float:
    """Largest initial bend y0_max of the shaft axis, m (eq. 11).

    y0_max = Δ_l·l with Δ_l the straightness deviation in mm per metre of GOST 5005-82 and l in
    metres (the paper's eq. 11 gives y0_max in mm), e.g. 0.4 mm/m × 1.4 m = 0.56 mm.
    """
    return mm_per_metre * length * 1e-3


def _subcritical_factor(omega, omega_cr):
    """1 - βω² = (1 - r)(1 + r), r = ω/ω_cr, raising at or above the critical speed.

    The factored form keeps full relative accuracy just below ω_cr, where 1 - r² would lose
    the digits that make 1 - r.
    """
    r = np.abs(np.asarray(omega, dtype=float)) / omega_cr
    if not np.all(np.isfinite(r)) or np.any(r >= 1.0):
        worst = float(np.max(np.abs(np.asarray(omega, dtype=float))))
        raise ProblemError(f"speed {worst:g} rad/s is at or above the first critical speed "
                           f"{omega_cr:g} rad/s (the model of eqs. 12-18 holds only below it)")
    return (1.0 - r) * (1.0 + r)


def amplification(omega, omega_cr: float):
    """Dynamic magnification of the initial bend, 1/(1 - βω²) (eqs. 12, 14).

    Eq. 12 gives the extra elastic deflection Δy_max(ω) = y0_max·βω²/(1 - βω²); eq. 9 adds it
    to y0_max, so y_max(ω)/y0_max = 1/(1 - βω²). Dimensionless, >= 1, finite below ω_cr.
    """
    return 1.0 / _subcritical_factor(omega, omega_cr)


def deflection(omega, omega_cr: float, y0_max: float):
    """Mid-span deflection y_max(ω) = y0_max/(1 - βω²) of the rotating shaft, m (eq. 14).

    This is the shaft with no correcting imbalances, or one balanced at low speed (the
    correcting masses' own effect on the bend, eq. 17's b, is neglected there as in eq. 10).
    """
    return y0_max * amplification(omega, omega_cr)


def principal_imbalance(mass: float, deflection_m):
    """Principal imbalance D0 = (5/8)·m·y_max in the mid-span plane, kg·m (eqs. 6, 7, 15).

    With y_max = y0_max/(1 - βω²) this is eq. 15. Multiply by 1e6 for g·mm.
    """
    return PRINCIPAL_IMBALANCE_FACTOR * mass * np.asarray(deflection_m, dtype=float)


def plane_shares(length: float, A: float, C: float) -> tuple[float, float]:
    """Shares of the mid-span imbalance carried to planes 1-1 and 2-2 (the levers of eq. 8).

    Plane 1-1 lies at A from support I, plane 2-2 at C from support II, so the mid-span plane
    is 0.5l - A from plane 1-1 and 0.5l - C from plane 2-2. Statics of a load between two
    planes: s1 = (0.5l - C)/(l - A - C), s2 = (0.5l - A)/(l - A - C), s1 + s2 = 1.
    """
    span = length - A - C
    return (0.5 * length - C) / span, (0.5 * length - A) / span


def corrections_static(D0, length: float, A: float, C: float):
    """Correcting imbalances (Dk1, Dk2) of a rigid shaft, kg·m (eq. 8, magnitudes).

    Dk1 = D0·(0.5l - C)/(l - A - C), Dk2 = D0·(0.5l - A)/(l - A - C), with the local
    imbalances D1, D2 of the planes taken as zero (ideal balancing, item 7 of the paper).
    With D0 = D0(ω_b) at the balancing speed ω_b this is eq. 10: the corrections a balancing
    machine running at ω_b installs.
    """
    s1, s2 = plane_shares(length, A, C)
    D0 = np.asarray(D0, dtype=float)
    return D0 * s1, D0 * s2


def coefficient_b(omega, mass: float, EI: float, length: float, A: float, C: float):
    """Coefficient b of eq. 17: how the correcting masses straighten the shaft they balance.

    b = (5/96)·(m·ω²/EI)·[A(0.5l - C)(¾l² - A²) + C(0.5l - A)(¾l² - C²)]/(l - A - C).

    The OCR shows the leading factor as "i/96"; we derived it again. Correcting imbalances
    Dk1 = X·s1 at x = A and Dk2 = X·s2 at x = l - C (:func:`plane_shares`) turn with the shaft
    and load it with forces ω²·Dk opposite to the bend. A point force F at a <= l/2 from a
    support deflects a pinned-pinned beam at mid-span by F·a(3l² - 4a²)/(48EI) =
    F·a(¾l² - a²)/(12EI), so the mid-span bend falls by
    Δy = ω²·X·[A·s1(¾l² - A²) + C·s2(¾l² - C²)]/(12EI), and D0 by (5/8)·m·Δy = b·X:
    (5/8)·(1/12) = 5/96. Units: kg·s⁻²·m⁴/(N·m²·m) = 1, b is dimensionless; b >= 0 and
    b -> 0 as ω -> 0. Requires 0 <= A, C <= l/2 (each plane between its support and the
    middle), where the point-load formula holds.
    """
    omega = np.asarray(omega, dtype=float)
    lever = (A * (0.5 * length - C) * (0.75 * length**2 - A**2)
             + C * (0.5 * length - A) * (0.75 * length**2 - C**2)) / (length - A - C)
    return 5.0 / 96.0 * mass * omega**2 / EI * lever


def balanced_imbalance(omega, omega_cr: float, mass: float, EI: float, y0_max: float,
                       length: float, A: float, C: float):
    """Principal imbalance X(ω) that a shaft balanced at its running speed ω carries, kg·m.

    X(ω) = (5/8)·m·y0_max/((1 - βω²)(1 + b)): the self-consistent D0 once the correcting
    imbalances -X·s1, -X·s2 are installed (they reduce the bend by b·X, eq. 17), since
    X = (5/8)·m·y0_max/(1 - βω²) - b·X. Eq. 16 is X times the plane shares.
    """
    b = coefficient_b(omega, mass, EI, length, A, C)
    return principal_imbalance(mass, y0_max) * amplification(omega, omega_cr) / (1.0 + b)


def corrections_balanced_at(omega, omega_cr: float, mass: float, EI: float, y0_max: float,
                            length: float, A: float, C: float):
    """Correcting imbalances (Dk1, Dk2) of a shaft balanced at its running speed ω, kg·m (eq. 16).

    Dk1(ω) = (5/8)·m·y0_max·1/(1 - βω²)·1/(1 + b)·(0.5l - C)/(l - A - C) and
    Dk2(ω) the same with (0.5l - A) (magnitudes; the paper's minus sign says they point
    against the bend). As ω -> 0 they tend to eq. 8 with D0 = (5/8)·m·y0_max.
    """
    X = balanced_imbalance(omega, omega_cr, mass, EI, y0_max, length, A, C)
    return corrections_static(X, length, A, C)


def deflection_balanced_at(omega, omega_cr: float, mass: float, EI: float, y0_max: float,
                           length: float, A: float, C: float):
    """Mid-span deflection of a shaft balanced at ω and running at ω, m (eq. 18).

    y_max(ω) = y0_max·1/(1 - βω²)·1/(1 + b): the bend of eq. 14 reduced by the correcting
    masses of eq. 16 (b of eq. 17).
    """
    b = coefficient_b(omega, mass, EI, length, A, C)
    return deflection(omega, omega_cr, y0_max) / (1.0 + b)

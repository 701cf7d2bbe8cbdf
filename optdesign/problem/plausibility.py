"""Values a problem file may hold that are valid but likely a unit mistake: warnings, not errors.

Lengths are in millimetres, angles in degrees and speeds in rad/s. A length under 1 mm or over
10 m, a least transmission angle under 2° (but not 0, which switches the rule off) and an input
speed over 1000 rad/s are each accepted and solved, and named with the likely mistake (metres,
radians, rpm): one :class:`~optdesign.errors.UnitWarning` per file, every suspicious key in it.
A correct file warns of nothing, so it needs no ``units:`` to be silent.

Fractions given in per cent. A ratio (output / input speed) and a ripple δ are fractions. A
ratio bound above 1 is warned ("per cent?"): only an overdrive linkage, whose output outruns
the crank, reaches it. It is not refused: the solve tells, at the cost of one relaxed solve,
that it is out of reach and how far (the largest ratio any design in the box reaches). A
ripple bound (``max_ripple``, ``constraints.ripple``) above 1 is warned, never refused: the
midrange δ = (ω_max − ω_min)/((ω_max + ω_min)/2) never exceeds 2, so a cap above it never
binds (a file may mean "no cap" by it).
"""
from __future__ import annotations

import math
import warnings

from optdesign.errors import ProblemError, UnitWarning
from optdesign.quantities.bounds import side_key

#: lengths below this (mm) are likely metres or centimetres
SHORTEST_MM = 1.0
#: lengths above this (mm, 10 m) are likely micrometres, or a slip of the keyboard
LONGEST_MM = 10_000.0
#: a least transmission angle below this (deg), but above 0, is likely radians
SMALLEST_ANGLE_DEG = 2.0
#: an input speed above this (rad/s) is likely rpm
FASTEST_INPUT = 1000.0


#: fraction bounds: quantity -> above this warned
FRACTION_LIMITS = {"ratio": 1.0, "ripple": 1.0}


def fraction_bounds(problem) -> list[tuple[str, str, float]]:
    """(key as the file wrote it, quantity, value) of every bound on a fraction (the ratio,
    the ripple) the problem holds."""
    spelled = problem.constraints.spelled
    out = []
    for bound in problem.constraints.bounds:
        if bound.name in FRACTION_LIMITS:
            for side in ("lower", "upper"):
                value = getattr(bound, side)
                if not math.isfinite(value) or (side == "lower" and value == 0):
                    continue
                out.append((side_key(spelled, bound, side), bound.name, value))
    return out


def _fraction_text(key: str, name: str, value: float) -> str:
    what = "ratio (output / input speed)" if name == "ratio" else "ripple δ"
    return (f"{key}: {value:g} is a {what}, a fraction (per cent? {value:g} % is "
            f"{value / 100:g})")


def implausible(problem) -> list[str]:
    """What in ``problem`` looks like a unit mistake, one phrase per key."""
    out = []
    for key, name, value in fraction_bounds(problem):
        if value > FRACTION_LIMITS[name]:
            extra = "; a ratio above 1 is an overdrive, which few linkages reach" \
                if name == "ratio" else "; the midrange δ never exceeds 2"
            out.append(_fraction_text(key, name, value) + extra)
    small, large = {}, {}
    for name in problem.model.lengths:
        v = problem.design[name]
        values = [x for x in (v.value, v.lower, v.upper, v.initial) if x is not None]
        if values and min(values) < SHORTEST_MM:
            small[name] = min(values)
        elif values and max(values) > LONGEST_MM:
            large[name] = max(values)
    if small:
        out.append(f"{_keys(small)} under {SHORTEST_MM:g} mm (down to {min(small.values()):g}): "
                   f"lengths are in mm (metres?)")
    if large:
        out.append(f"{_keys(large)} over {LONGEST_MM / 1000:g} m (up to "
                   f"{max(large.values()):g} mm): lengths are in mm")
    angle = problem.constraints.min_transmission_angle_deg
    if 0 < angle < SMALLEST_ANGLE_DEG:
        out.append(f"constraints.min_transmission_angle_deg: {angle:g} deg is under "
                   f"{SMALLEST_ANGLE_DEG:g} deg (radians? {angle:g} rad is "
                   f"{math.degrees(angle):.1f} deg)")
    if problem.input_speed > FASTEST_INPUT:
        out.append(f"input_speed: {problem.input_speed:g} rad/s is over {FASTEST_INPUT:g} "
                   f"rad/s (rpm? {problem.input_speed:g} rpm is "
                   f"{problem.input_speed * math.pi / 30:.4g} rad/s)")
    return out


def _keys(found: dict) -> str:
    names = [f"design.{k}" for k in found]
    return f"{names[0]} is" if len(names) == 1 else f"{', '.join(names)} are"


def warn_implausible(problem) -> None:
    """One :class:`UnitWarning` naming the file and every key of :func:`implausible`."""
    found = implausible(problem)
    if found:
        warnings.warn(UnitWarning(f"{problem.source}: " + "; ".join(found)), stacklevel=3)

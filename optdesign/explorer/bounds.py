"""The bounds a designer moves in the explorer: every constraint's bound, by its file key.

A bound is named by the problem file's key that sets it, as the user wrote it
(:meth:`optdesign.quantities.criteria.Constraint.key`: ``constraints.min_transmission_angle_deg``,
``objective.min_ratio``, ``constraints.min_pin_radius``, ``constraints.housing_radius.upper``).
Moving one writes the new value at that key of the file's mapping and loads the mapping again
(:func:`optdesign.problem.loader.problem_from_dict`): a value the loader refuses is refused
with the loader's own one-line message, and every bound stays where a file could put it.
"""
from __future__ import annotations

import copy
import math
import re
from dataclasses import dataclass

from optdesign.errors import ProblemError
from optdesign.quantities.criteria import (LengthConstraint, QuantityConstraint, RatioFloor,
                                           RippleCap, TransmissionAngle, bounded_sides,
                                           constraints_of)

#: a key path of the problem file (a constraint checked by a formula of the design's own
#: keys, such as the slotted lever's ``design.L (below design.XD)``, has no bound to move)
_FILE_KEY = re.compile(r"(constraints|objective)(\.[A-Za-z_][A-Za-z0-9_]*)+")


@dataclass(frozen=True)
class Bound:
    """One bound of a constraint: its file key, what it bounds, its value and a range for
    a slider (the number field beside it takes any value the loader admits)."""

    key: str
    label: str
    unit: str
    value: float
    lower: float
    upper: float
    side: str                   # "lower" or "upper": which side of the quantity it bounds

    @property
    def step(self) -> float:
        """A slider step: about a thousandth of the range, rounded to 1, 2 or 5."""
        raw = (self.upper - self.lower) / 1000
        exponent = math.floor(math.log10(raw)) if raw > 0 else -3
        mantissa = raw / 10 ** exponent
        return next(m for m in (1, 2, 5, 10) if m >= mantissa) * 10 ** exponent


def bounds_of(problem) -> list[Bound]:
    """Every bound of ``problem``'s constraints a slider can move, in the order of
    :func:`~optdesign.quantities.criteria.constraints_of`."""
    out = []
    for c in constraints_of(problem):
        key = c.key(problem)
        if isinstance(c, TransmissionAngle):
            out.append(Bound(key, "least transmission angle", "deg",
                             problem.constraints.min_transmission_angle_deg, 0.0, 89.0, "lower"))
        elif isinstance(c, RatioFloor):
            value = problem.constraints.min_ratio
            out.append(Bound(key, "least ratio", "-", value, 0.0, _span(value, 1.0), "lower"))
        elif isinstance(c, RippleCap) and problem.constraints.max_ripple is not None:
            value = problem.constraints.max_ripple
            out.append(Bound(key, "largest δ", "-", value, 0.0, _span(value, 1.0), "upper"))
        elif isinstance(c, LengthConstraint) and _FILE_KEY.fullmatch(key) \
                and _declared_number(problem, key):
            side = "lower" if math.isfinite(c.lower) else "upper"
            value = c.lower if side == "lower" else c.upper
            box = max(v.upper if v.is_free else v.value
                      for k, v in problem.design.items() if k in problem.model.lengths)
            out.append(Bound(key, f"{'least' if side == 'lower' else 'largest'} "
                             f"{c.name.replace('_', ' ')}",
                             c.unit, value, 0.0, _span(value, box), side))
        elif isinstance(c, QuantityConstraint):
            for side in sorted(bounded_sides(c.spec)):
                value = getattr(c.spec, side)
                name = f"constraints.{c.spec.name}.{side}"
                unit = c.unit or "-"
                out.append(Bound(name, f"{c.spec.name} {side} bound", unit, value,
                                 min(0.0, 2 * value), _span(value, 1.0), side))
    return out


def _span(value: float, scale: float) -> float:
    """A slider's upper end for a bound at ``value``: twice it, at least ``scale``."""
    return max(2 * abs(value), scale)


def _declared_number(problem, key: str) -> bool:
    """Whether ``key`` is a number the mechanism declares under ``constraints:`` (not a
    switch such as ``grashof``)."""
    name = key.split(".", 1)[1]
    return any(k.name == name and k.kind == "number"
               for k in problem.model.constraint_declarations)


def with_bound(data: dict, key: str, value: float) -> dict:
    """A copy of the problem file's mapping ``data`` with ``value`` at the dotted ``key``
    (the mappings on the way made when missing)."""
    out = copy.deepcopy(data)
    node = out
    *path, last = key.split(".")
    for part in path:
        child = node.get(part)
        if child is None:
            child = node[part] = {}
        elif not isinstance(child, dict):
            raise ProblemError(f"{key}: {part} is not a mapping in the problem file")
        node = child
    node[last] = value
    return out


def moved(problem, data: dict, key: str, value: float):
    """(``problem`` with its bound at ``key`` moved to ``value``, the file's mapping so
    changed): loaded by the loader's rules, so a value it refuses raises its
    :class:`~optdesign.errors.ProblemError` naming the key."""
    from optdesign.problem.loader import problem_from_dict

    if key not in {b.key for b in bounds_of(problem)}:
        raise ProblemError(f"{problem.source}: {key} is not a bound of this problem (its "
                           f"bounds: {', '.join(b.key for b in bounds_of(problem))})")
    changed = with_bound(data, key, value)
    return problem_from_dict(changed, where=problem.source), changed

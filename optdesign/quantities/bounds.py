"""Bounds on quantities in a problem file: ``constraints: {QUANTITY: {lower, upper, at}}``.

A bound holds a quantity's value at one listed eccentricity (``at: 0.5``) or its worst over
the listed ones (``at: worst``, the default; the ratio's own default is e = 1). Every quantity
takes a bound on either side or both: on the side where it grows worse (an upper bound on the
housing radius, a lower one on the swing) the NLP holds every tracked extreme within it; on the
other side (a housing at least so large, a ratio band's cap) it holds the extreme the design
attains (:mod:`optdesign.solver.nlp`). Three bounds are the file's older keys under a new
name, with the same meaning:
``ratio: {lower}`` is ``objective.min_ratio``, ``ripple: {upper}`` is ``objective.max_ripple``
and ``transmission_angle: {lower}`` is ``constraints.min_transmission_angle_deg``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from optdesign.declarations import Key
from optdesign.quantities import get_quantity, known

#: quantities a bound may name at a single eccentricity (``at: E``)
AT_ONE_ECCENTRICITY = frozenset({"housing_radius", "peak_acceleration", "swing", "peak_speed",
                                 "ripple"})
#: the older keys each alias stands for: (section, key) per (quantity, side)
ALIASES = {("ratio", "lower"): ("objective", "min_ratio"),
           ("ripple", "upper"): ("objective", "max_ripple"),
           ("transmission_angle", "lower"): ("constraints", "min_transmission_angle_deg")}


@dataclass(frozen=True)
class QuantityBound:
    """``lower <= value <= upper`` of quantity ``name`` at ``at`` (None: its default)."""

    name: str
    lower: float = -math.inf
    upper: float = math.inf
    at: float | None = None

    @property
    def key(self) -> str:
        """The bound's name in results and the NLP: ``housing_radius`` or ``swing@0.5``."""
        return self.name if self.at is None else f"{self.name}@{self.at:g}"


def declarations() -> tuple[Key, ...]:
    """One ``constraints:`` key per quantity, for the loader and the generated reference."""
    out = []
    for name in known():
        q = get_quantity(name)
        sides = _sides(q)
        keys = tuple(Key(side, "number", f"the {side} bound", unit=q.unit,
                         default_text="none") for side in sides)
        at = Key("at", "either", "the eccentricity the bound holds at: worst (over the listed "
                 "ones) or one listed fraction", unit="-", default_text="worst",
                 alternatives=(Key("at", "choice", "the worst", choices=("worst",)),
                               Key("at", "number", "a listed fraction", lower=0,
                                   open_lower=True, upper=1)))
        alias = [f"{side}: {'.'.join(ALIASES[(name, side)])}" for side in sides
                 if (name, side) in ALIASES]
        when = " under minimize: -ratio or phases" if name == "ripple" else ""
        meaning = f"bound on the {q.meaning}" + (
            f" ({', '.join(alias)}{when} is the same bound)" if alias else "")
        out.append(Key(name, "mapping", meaning, unit=q.unit, default_text="none",
                       keys=keys + ((at,) if name in AT_ONE_ECCENTRICITY else ()),
                       example={sides[0]: _EXAMPLES.get(name, 1.0)},
                       condition="a bound on a quantity"))
    return tuple(out)


def _sides(quantity) -> tuple[str, str]:
    """A quantity's sides, the one where it grows worse first (the reference's example)."""
    natural = quantity.natural_side()
    return (natural, "upper" if natural == "lower" else "lower")


#: a plausible bound per quantity, for the generated reference and the starting file
_EXAMPLES = {"housing_radius": 280.0, "peak_acceleration": 5000.0, "swing": 20.0,
             "peak_speed": 40.0, "ratio": 0.3, "ripple": 0.2, "transmission_angle": 40.0}


def read_bound(r, name: str, raw, eccentricities) -> QuantityBound:
    """The bound ``constraints.NAME`` of a file (``r``: the loader's Reader), checked: a
    mapping of the quantity's sides and ``at``, a side given, lower below upper, ``at`` one
    of ``eccentricities``."""
    q = get_quantity(name)
    where = f"constraints.{name}"
    block = r.mapping(raw, where)
    sides = _sides(q)
    allowed = set(sides) | ({"at"} if name in AT_ONE_ECCENTRICITY else set())
    r.known_keys(block, where, allowed)
    values = {side: r.number(block[side], f"{where}.{side}") for side in sides if side in block}
    if not values:
        raise r.error(where, f"needs a bound: {' or '.join(sides)}")
    lower, upper = values.get("lower", -math.inf), values.get("upper", math.inf)
    if lower > upper:
        raise r.error(f"{where}.upper", f"must not be below lower (got {upper:g} < {lower:g})")
    at = block.get("at", "worst")
    if at == "worst":
        at = None
    else:
        e = r.number(at, f"{where}.at")
        if e not in eccentricities:
            listed = ", ".join(f"{x:g}" for x in eccentricities)
            raise r.error(f"{where}.at", f"must be worst or a listed eccentricity ({listed}); "
                                         f"got {e:g}")
        at = e
    return QuantityBound(name, lower, upper, at)

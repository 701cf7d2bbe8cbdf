"""Bounds on quantities in a problem file: ``constraints: {QUANTITY: {lower, upper, at}}``.

A bound holds a quantity's value at one listed eccentricity (``at: 0.5``) or its worst over
the listed ones (``at: worst``, the default; the ratio's own default is e = 1). Every quantity
takes a bound on either side or both: on the side where it grows worse (an upper bound on the
housing radius, a lower one on the swing) the NLP holds every tracked extreme within it; on the
other side (a housing at least so large, a ratio band's cap) it holds the extreme the design
attains (:mod:`optdesign.solver.nlp`).

Every bound of a problem is stored here, one :class:`QuantityBound` per key, whichever key of
the file gave it. Three older keys are read into bounds, with the same meaning:
``objective.min_ratio`` is ``ratio: {lower}``, ``objective.max_ripple`` is ``ripple: {upper}``
and ``constraints.min_transmission_angle_deg`` is ``transmission_angle: {lower}``. Those sides
(and the ripple's cap where the objective brings one: the largest ratio, the least count) are
held by the envelope's own criteria (:data:`ENVELOPE_SIDES`,
:mod:`optdesign.quantities.criteria`), every other side as a bound on a quantity.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

from optdesign.declarations import Key
from optdesign.quantities import get_quantity, known

#: quantities a bound may name at a single eccentricity (``at: E``)
AT_ONE_ECCENTRICITY = frozenset({"housing_radius", "peak_acceleration", "swing", "peak_speed",
                                 "ripple"})
#: the older keys each alias stands for: (section, key) per (quantity, side)
ALIASES = {("ratio", "lower"): ("objective", "min_ratio"),
           ("ripple", "upper"): ("objective", "max_ripple"),
           ("transmission_angle", "lower"): ("constraints", "min_transmission_angle_deg")}
#: the sides held by a criterion of the envelope's own in every problem (the ratio's floor,
#: the transmission angle's floor); :data:`RIPPLE_CAP` too where the objective brings the cap
ENVELOPE_SIDES = frozenset({("ratio", "lower"), ("transmission_angle", "lower")})
RIPPLE_CAP = ("ripple", "upper")


@dataclass(frozen=True)
class QuantityBound:
    """``lower <= value <= upper`` of quantity ``name`` at ``at`` (None: its default)."""

    name: str
    lower: float = -math.inf
    upper: float = math.inf
    at: float | None = None
    #: held as a bound on the quantity (its NLP rows built: a Pareto axis, a figure read off
    #: the screening) though every side it bounds is held by an envelope criterion
    tracked: bool = False

    @property
    def key(self) -> str:
        """The bound's name in results and the NLP: ``housing_radius`` or ``swing@0.5``."""
        return self.name if self.at is None else f"{self.name}@{self.at:g}"


def file_key(spelled, name: str, side: str) -> str:
    """The problem file's key of one side of the bound on ``name`` (at its default
    eccentricity): as the file spelled it (``spelled``: :attr:`Constraints.spelled`), else the
    older key where there is one (``objective.min_ratio``), else ``constraints.NAME.SIDE``."""
    alias = ALIASES.get((name, side))
    return spelled.get(f"{name}.{side}") or (".".join(alias) if alias else
                                              f"constraints.{name}.{side}")


def side_key(spelled, bound: QuantityBound, side: str) -> str:
    """The problem file's key of one side of ``bound``: :func:`file_key` at the default
    eccentricity, ``constraints.NAME@E.SIDE`` for a bound at an eccentricity of its own."""
    return file_key(spelled, bound.name, side) if bound.at is None else \
        f"constraints.{bound.key}.{side}"


def held_apart(ripple_capped: bool) -> frozenset:
    """The (quantity, side) pairs a criterion of the envelope's own holds: the floors always,
    the ripple's cap where the objective brings it (``ripple_capped``)."""
    return ENVELOPE_SIDES | {RIPPLE_CAP} if ripple_capped else ENVELOPE_SIDES


def side_of(bounds, name: str, side: str) -> float:
    """The ``side`` of the bound on ``name`` at its default eccentricity among ``bounds``
    (±inf where there is none)."""
    for b in bounds:
        if b.name == name and b.at is None:
            return getattr(b, side)
    return -math.inf if side == "lower" else math.inf


def with_side(bounds, name: str, side: str, value: float | None) -> tuple:
    """``bounds`` with the ``side`` of the bound on ``name`` (at its default eccentricity)
    set to ``value``, or dropped where ``value`` is None."""
    if value is None:
        value = -math.inf if side == "lower" else math.inf
    out, found = [], False
    for b in bounds:
        if b.name == name and b.at is None:
            found = True
            b = replace(b, **{side: float(value)})
            if not (_bounded(b) or b.tracked):
                continue            # nothing left of it
        out.append(b)
    if not found and math.isfinite(value):
        out.append(replace(QuantityBound(name), **{side: float(value)}))
    return ordered(out)


def ordered(bounds) -> tuple:
    """One bound per key (the last given), in the order the keys first come."""
    return tuple({b.key: b for b in bounds}.values())


def _bounded(b: QuantityBound) -> bool:
    return math.isfinite(b.lower) or math.isfinite(b.upper)


def generic(bounds, apart: frozenset) -> tuple:
    """The bounds held as bounds on a quantity: each of ``bounds`` without its sides in
    ``apart`` (at its default eccentricity), dropped where nothing is left of it; a bound
    that tracks a quantity without a side is kept."""
    out = []
    for b in bounds:
        rest = b
        if b.at is None:
            for side in ("lower", "upper"):
                if (b.name, side) in apart:
                    rest = replace(rest, **{side: -math.inf if side == "lower" else math.inf})
        if _bounded(rest) or not _bounded(b) or b.tracked:
            out.append(replace(rest, tracked=False))
    return tuple(out)


def with_generic(bounds, specs, apart: frozenset) -> tuple:
    """``bounds`` with ``specs`` as the bounds held on quantities: the sides in ``apart``
    kept from ``bounds``, every other side from ``specs``."""
    kept = {s.key: s for s in specs}
    for b in bounds:
        if b.at is not None:
            continue
        for side in ("lower", "upper"):
            value = getattr(b, side)
            if (b.name, side) in apart and math.isfinite(value):
                spec = kept.get(b.key)
                spec = QuantityBound(b.name) if spec is None else \
                    replace(spec, tracked=spec.tracked or not _bounded(spec))
                kept[b.key] = replace(spec, **{side: value})
    return ordered(kept.values())


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
        meaning = f"bound on the {q.meaning}" + (
            f" ({', '.join(alias)} is the same bound)" if alias else "")
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

"""Quantities: one vocabulary for every figure of a design that a criterion, a front or a
report names (:mod:`optdesign.quantities.base`).

Every module of :mod:`optdesign.quantities.catalog` that defines a
:class:`~optdesign.quantities.base.Quantity` subclass with a ``name`` contributes it: a new
quantity is one new module there, found by :func:`known` with nothing else to edit. The
criteria over quantities (objectives, constraints) are :mod:`optdesign.quantities.criteria`,
their bounds in a problem file :mod:`optdesign.quantities.bounds`.
"""
from __future__ import annotations

import importlib
import pkgutil
from functools import lru_cache

from optdesign.quantities import catalog
from optdesign.quantities.base import Quantity, TurnQuantity

__all__ = ["Quantity", "TurnQuantity", "design_quantities", "get_quantity", "known",
           "quantities_of"]


@lru_cache(maxsize=1)
def _registry() -> dict[str, Quantity]:
    found: dict[str, Quantity] = {}
    for info in sorted(pkgutil.iter_modules(catalog.__path__), key=lambda m: m.name):
        module = importlib.import_module(f"optdesign.quantities.catalog.{info.name}")
        for value in vars(module).values():
            if isinstance(value, type) and issubclass(value, Quantity) and value.name and \
                    value.__module__ == module.__name__:
                found[value.name] = value()
    return found


def known() -> tuple[str, ...]:
    """The names of every quantity, in order."""
    return tuple(sorted(_registry()))


def get_quantity(name: str) -> Quantity:
    """The quantity ``name`` (KeyError naming the known ones)."""
    try:
        return _registry()[name]
    except KeyError:
        raise KeyError(f"unknown quantity {name!r}; known: {', '.join(known())}") from None


def unit_text(name: str) -> str:
    """" mm" after a value of quantity ``name`` (nothing for a unitless one)."""
    unit = get_quantity(name).unit
    return "" if unit == "-" else f" {unit}"


def quantities_of(evaluation, eccentricities, ripple: str = "midrange",
                  names=None) -> dict:
    """Every quantity's exact value (or those ``names``) of an evaluated design:
    ``{"values": {name: value}, "per_eccentricity": [{"eccentricity": e, name: value}]}``,
    and with a searched regulation interval ``"interval": {name: {"eccentricity", "value"}}``,
    each searched quantity's worst over the interval and where it lies.

    ``values`` holds what a criterion reads: the value at the quantity's own eccentricity
    (:attr:`~optdesign.quantities.base.Quantity.at`: the ratio's is e = 1) or else the worst
    over ``eccentricities`` and, for those the evaluation searched over the regulation
    interval (the ripple, the transmission angle and the quantities its criteria name), the
    worst over the whole interval."""
    names = tuple(n for n in (names or known())
                  if get_quantity(n).defined_for(evaluation.design))
    rows = []
    for e in eccentricities:
        row = {"eccentricity": float(e)}
        for name in names:
            row[name] = float(get_quantity(name).exact(evaluation, e, ripple))
        rows.append(row)
    values = {}
    for name in names:
        q = get_quantity(name)
        values[name] = float(q.exact(evaluation, q.at, ripple)) if q.at is not None else \
            q.worst_of([r[name] for r in rows])
    out = {"values": values, "per_eccentricity": rows}
    searched = _interval_worst(evaluation, ripple)
    searched = {k: v for k, v in searched.items() if k in values}
    for name, (e, value) in searched.items():
        values[name] = get_quantity(name).worst_of([values[name], value])
    if searched:
        out["interval"] = {name: {"eccentricity": e, "value": value}
                           for name, (e, value) in searched.items()}
    return out


def _interval_worst(evaluation, ripple: str) -> dict[str, tuple[float, float]]:
    """(e, worst value) over the regulation interval of every quantity the evaluation
    searched there (:class:`~optdesign.evaluation.regulation.RangeWorst`)."""
    interval = evaluation.worst
    if interval is None:
        return {}
    out = {"transmission_angle": (interval.angle_eccentricity, interval.min_angle_deg)}
    if evaluation.worst_definition == ripple:
        out["ripple"] = (interval.eccentricity, interval.delta)
    return out | dict(interval.quantities)


def design_quantities(problem, evaluation) -> dict:
    """:func:`quantities_of` an evaluation of the problem's design at its listed
    eccentricities, its ripple by the problem's definition (empty when it does not
    assemble)."""
    if evaluation is None or not evaluation.assembles:
        return {}
    return quantities_of(evaluation, problem.eccentricities, problem.objective.ripple)

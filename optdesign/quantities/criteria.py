"""Objectives and constraints as objects: each owns its expression, its bounds and its check.

One object per criterion states the same quantity twice over one interface: symbolically, over
the NLP's named quantities (:class:`optdesign.solver.nlp.Quantities`: ``lengths``, ``ratio``,
``worst_ripple``, ``peak_speed``, ``cos_mu_sq``), and exactly, over a :class:`Measured` view of
an :class:`~optdesign.evaluation.figures.Evaluation` with the same names. The NLP, the verification, the
start ranking and the reports iterate over :func:`constraints_of` and :func:`objective_of`; a
new criterion is one class here (or in its mechanism or section) and nothing else.

Convention, stated once: every constraint is ``lower <= value <= upper``; its bounds are
computed anew for every solve (a Pareto sweep's ε is a bound, not a rebuild of the NLP).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from functools import lru_cache
from typing import Any, Mapping

from optdesign.quantities import TurnQuantity, get_quantity, known, quantities_of
from optdesign.quantities.bounds import QuantityBound, file_key

#: weight of the worst ripple in the largest-ratio objective: a lexicographic tie-break that
#: keeps w_hi and w_lo tight when the ripple cap is slack (the surrogate δ stays exact) for
#: at most ~1e-6 of ratio
RIPPLE_TIE_BREAK = 1e-6
#: tolerances of the exact check: a constraint violated by less is taken as met
TOL_ANGLE_DEG = 1e-3
TOL_RATIO = 1e-7
#: length constraints, relative to the design's longest length: 4e-5 mm at 400 mm, far below
#: any manufacturing tolerance, and the same in any unit
TOL_LENGTH_REL = 1e-7
#: bounds on quantities, relative to the value (at least 1 in its unit)
TOL_QUANTITY_REL = 1e-7


@dataclass(frozen=True)
class Measured:
    """The NLP's named quantities, measured exactly on one evaluated design."""

    lengths: Mapping[str, float]
    ratio: float
    worst_ripple: float
    peak_speed: float                 # ω_max of the problem's stroke at e = 1, rad/s
    min_angle_deg: float
    evaluation: Any
    #: the exact value of every quantity a bound or the objective of the problem names, by
    #: the bound's key (:attr:`QuantityBound.key`)
    quantities: Mapping[str, float] = field(default_factory=dict)

    @classmethod
    def of(cls, problem, ev) -> "Measured":
        lengths = {k: float(ev.design.values[k]) for k in problem.model.lengths}
        listed = problem.eccentricities
        return cls(lengths, ev.ratio, ev.ripple(problem.objective.ripple, listed),
                   ev.figures.omega_max, ev.min_angle_deg, ev,
                   measured_quantities(problem, ev))


def quantity_specs(problem) -> list[QuantityBound]:
    """The quantities the problem's criteria read beyond the envelope's own: its bounds on
    quantities and its quantity objective, each once by key."""
    specs = list(problem.quantity_bounds)
    objective = objective_of(problem)
    if isinstance(objective, QuantityObjective):
        specs.append(QuantityBound(objective.quantity))
    return list({s.key: s for s in specs}.values())


#: the quantities the regulation interval's own search always covers
SEARCHED_ALWAYS = frozenset({"ripple", "transmission_angle"})


def interval_quantities(problem) -> tuple[str, ...]:
    """The quantities whose worst over the regulation interval a criterion of ``problem``
    reads (a bound or the objective ``at: worst``), besides those the interval's search
    always covers and those read at an eccentricity of their own (the ratio at e = 1)."""
    if problem.eccentricity_range is None:
        return ()
    return tuple(sorted({s.name for s in quantity_specs(problem)
                         if s.at is None and get_quantity(s.name).at is None
                         and s.name not in SEARCHED_ALWAYS}))


def searched_quantities(design) -> tuple[str, ...]:
    """Every quantity of ``design`` a report gives the worst over a regulation interval of:
    all but those the interval's search always covers and those read at an eccentricity of
    their own (the ratio)."""
    return tuple(n for n in known() if n not in SEARCHED_ALWAYS and get_quantity(n).at is None
                 and get_quantity(n).defined_for(design))


def value_of(problem, spec: QuantityBound, ev) -> float:
    """The exact value of ``spec``'s quantity on an evaluation of ``problem``'s design: at
    its eccentricity, or its worst over the listed ones (and the regulation interval)."""
    if spec.at is None:
        return quantities_of(ev, problem.eccentricities, problem.objective.ripple,
                             names=(spec.name,))["values"][spec.name]
    return float(get_quantity(spec.name).exact(ev, spec.at, problem.objective.ripple))


def measured_quantities(problem, ev) -> dict[str, float]:
    """The exact value of every :func:`quantity_specs` of ``problem`` on the evaluation."""
    return {spec.key: value_of(problem, spec, ev) for spec in quantity_specs(problem)}


# --------------------------------------------------------------------------- constraints
class Constraint:
    """``lower <= value(q) <= upper`` on the NLP's quantities and on a measured design."""

    name: str = ""
    unit: str = ""
    #: the NLP holds it at tracked extremes, and a violation the exact check still finds
    #: between them tightens the NLP's bound by that much (``tightening_deg``)
    tightens: bool = False

    def rows(self, q) -> list[tuple[str, Any]]:
        """(block name, CasADi expression) pairs for the NLP."""
        return [(self.name, self.value(q))]

    def value(self, q):
        raise NotImplementedError

    def bounds(self, problem, tightening_deg: float = 0.0) -> tuple[float, float]:
        raise NotImplementedError

    def tolerance(self, m: Measured) -> float:
        return TOL_RATIO

    def key(self, problem) -> str:
        """The problem file's key of this constraint, as the user wrote it (messages name
        it, never an NLP row)."""
        return f"constraints.{self.name}"

    def quantity_bound(self, problem) -> QuantityBound | None:
        """The bound on a quantity this constraint holds (the older keys read as one:
        ``min_ratio`` is the ratio's lower bound), or None where it bounds no quantity."""
        return None

    def without(self, problem):
        """``problem`` with this constraint dropped (every other kept)."""
        raise NotImplementedError

    def row_bounds(self, problem, row: str, tightening_deg: float = 0.0) -> tuple[float, float]:
        """The bounds of one of its NLP rows (by the row's name): :meth:`bounds` unless the
        rows hold another figure of the value."""
        return self.bounds(problem, tightening_deg)

    def bound_per_unit(self, problem, lower: bool) -> tuple[float, str]:
        """How the NLP row's bound moves per unit of the designer's bound, and that unit:
        IPOPT's multiplier of a row times this is d objective / d (the file's value)."""
        return 1.0, self.unit or "-"

    def violation(self, problem, m: Measured) -> float:
        """How far the exact value lies outside the bounds (<= 0 when met)."""
        lower, upper = self.bounds(problem)
        v = self.value(m)
        values = v if isinstance(v, (list, tuple)) else [v]
        return max(max(lower - float(x), float(x) - upper) for x in values)


class TransmissionAngle(Constraint):
    """min(μ, 180° - μ) >= μ_min of every chain over the whole turn, as |cos μ| <= cos μ_min
    at the NLP's exact extremes of cos μ (squared, so both toggle sides are one smooth row),
    tightened by any deficit the exact check still finds; assembly with a margin,
    1 - cos²μ >= m."""

    name = "transmission_angle"
    unit = "deg"
    tightens = True

    def rows(self, q):
        return [(f"{self.name}[{tag}]", cos_sq) for tag, cos_sq in q.cos_mu_sq.items()]

    def bounds(self, problem, tightening_deg=0.0):
        c = problem.constraints
        mu = min(c.min_transmission_angle_deg + tightening_deg, 89.0) \
            if c.min_transmission_angle_deg > 0 else 0.0
        return -math.inf, min(math.cos(math.radians(mu)) ** 2, 1.0 - c.assembly_margin)

    def violation(self, problem, m):
        return problem.constraints.min_transmission_angle_deg - m.min_angle_deg

    def key(self, problem):
        return file_key(problem.constraints.spelled, "transmission_angle", "lower")

    def quantity_bound(self, problem):
        mu = problem.constraints.min_transmission_angle_deg
        return QuantityBound("transmission_angle", lower=mu) if mu > 0 else None

    def without(self, problem):
        return problem.with_limit("transmission_angle", "lower", None)

    def bound_per_unit(self, problem, lower):
        """The row's bound is cos²μ_min: d cos²μ_min / dμ_min = -sin 2μ_min per radian."""
        mu = math.radians(problem.constraints.min_transmission_angle_deg)
        return -math.sin(2 * mu) * math.pi / 180.0, "deg"

    def tolerance(self, m):
        return TOL_ANGLE_DEG


class RatioFloor(Constraint):
    """ratio >= min_ratio (the ε of a Pareto sweep)."""

    name = "min_ratio"

    def value(self, q):
        return q.ratio

    def bounds(self, problem, tightening_deg=0.0):
        return problem.constraints.min_ratio, math.inf

    def key(self, problem):
        return file_key(problem.constraints.spelled, "ratio", "lower")

    def quantity_bound(self, problem):
        floor = problem.constraints.min_ratio
        return QuantityBound("ratio", lower=floor) if floor > 0 else None

    def without(self, problem):
        return problem.with_limit("ratio", "lower", None)


class RippleCap(Constraint):
    """worst δ <= max_ripple, with the largest-ratio objective and the least count."""

    name = "max_ripple"

    def value(self, q):
        return q.worst_ripple

    def bounds(self, problem, tightening_deg=0.0):
        return -math.inf, problem.constraints.max_ripple

    def key(self, problem):
        return file_key(problem.constraints.spelled, "ripple", "upper")

    def quantity_bound(self, problem):
        cap = problem.constraints.max_ripple
        return QuantityBound("ripple", upper=cap) if cap is not None else None

    def without(self, problem):
        return problem.with_limit("ripple", "upper", None)


class LengthConstraint(Constraint):
    """A constraint on the lengths alone, with one formula for symbols and numbers:
    ``formula(lengths)`` uses arithmetic only. Mechanisms contribute these."""

    def __init__(self, name: str, formula, lower: float = 0.0, upper: float = math.inf,
                 column: str | None = None, unit: str = "mm", at_zero: str = "",
                 meaning: str = "", file_key: str | None = None):
        self.name, self.formula, self.lower, self.upper = name, formula, lower, upper
        #: the problem file's key that sets the bound (default ``constraints.NAME``)
        self.file_key = file_key
        self.column = column            # the result tables' column of this value, if any
        self.unit = unit                # of the formula's value: mm, or "-" for a ratio
        self.meaning = meaning          # what the value is, in the mechanism's words
        #: what the linkage becomes with this value held at zero, in the mechanism's words
        #: (the summary warns of it)
        self.at_zero = at_zero

    def value(self, q):
        return self.formula(q.lengths)

    def bounds(self, problem, tightening_deg=0.0):
        """Its bounds as ``problem`` sets them (the mechanism's constraint of this name
        in ``problem``), or its own where ``problem`` has none: an NLP built once reads a
        moved bound from the problem of each solve, as it reads the others."""
        if problem is None:
            return self.lower, self.upper
        same = next((c for c in problem.model.criteria(problem.constraints, problem.options)
                     if isinstance(c, LengthConstraint) and c.name == self.name), self)
        return same.lower, same.upper

    def tolerance(self, m):
        return TOL_LENGTH_REL * max(abs(v) for v in m.lengths.values())

    def key(self, problem):
        return self.file_key or super().key(problem)


def result_columns(problem) -> dict[str, str]:
    """The columns the problem's criteria add to a result table (a ``LengthConstraint`` with
    a ``column``: the four-bar's ``pin_radius``), each with its unit and meaning."""
    return {c.column: f"{c.unit} ({c.meaning})" if c.meaning else c.unit
            for c in constraints_of(problem) if isinstance(c, LengthConstraint) and c.column}


def bounded_sides(spec: QuantityBound) -> frozenset[str]:
    """The sides ``spec`` bounds: ``lower``, ``upper`` or both."""
    return frozenset(side for side in ("lower", "upper")
                     if math.isfinite(getattr(spec, side)))


def spec_sides(problem, specs) -> dict[str, frozenset[str]]:
    """Per spec key, the sides the problem holds or pushes that quantity towards: its bounds'
    (``lower``, ``upper``) and the objective's (``lower`` when maximised, ``upper`` when
    minimised)."""
    objective = objective_of(problem)
    out = {s.key: frozenset() for s in specs}
    for spec in problem.quantity_bounds:
        out[spec.key] = out.get(spec.key, frozenset()) | bounded_sides(spec)
    if isinstance(objective, QuantityObjective) and objective.quantity in out:
        out[objective.quantity] |= {"lower" if objective.maximize else "upper"}
    return out


def spec_forms(problem, specs, sides: dict) -> dict[str, frozenset[str]]:
    """Per spec key, the NLP forms it needs (``sides``: :func:`spec_sides`): ``natural`` for
    its natural side (and where nothing bounds it: it is read over the regulation interval),
    ``attained`` for the other."""
    out = {}
    bounded = {s.key for s in problem.quantity_bounds}   # a row each, always
    for key, sides in sides.items():
        natural = get_quantity(next(s.name for s in specs if s.key == key)).natural_side()
        forms = {"natural"} if natural in sides or key in bounded else set()
        out[key] = frozenset(forms | ({"attained"} if sides - {natural} else set()) or
                             {"natural"})
    return out


def quantity_tolerance(value) -> float:
    """The exact check's tolerance of a quantity's bound at ``value``: relative, at least
    TOL_QUANTITY_REL in the quantity's unit (the NLP holds the bound to IPOPT's tolerance)."""
    return TOL_QUANTITY_REL * max(1.0, abs(float(value)))


def bound_excess(spec: QuantityBound, value: float) -> float:
    """How far ``value`` lies outside ``spec``'s bounds beyond :func:`quantity_tolerance`
    (> 0: the bound is broken)."""
    return max(spec.lower - value, value - spec.upper) - quantity_tolerance(value)


#: the suffix of the NLP row that holds a bound on a quantity's other side
ATTAINED = ".attained"


class QuantityConstraint(Constraint):
    """``lower <= value <= upper`` of a quantity (``constraints: {QUANTITY: {...}}``): the
    NLP holds the bound on the quantity's natural side at its natural form (the epigraph of
    its figures, conservative: every tracked extreme within the bound) and a bound on the
    other side at its attained form (a figure the design reaches, picked at the start), each
    in the NLP's figure of the value (:meth:`~optdesign.quantities.base.Quantity.to_figure`);
    the exact check reads the quantity's exact form."""

    def __init__(self, spec: QuantityBound):
        self.spec = spec
        self.name = spec.key
        self.unit = get_quantity(spec.name).unit
        self.column = spec.key

    def value(self, q):
        return q.quantities[self.spec.key]

    def rows(self, q):
        """The natural side's row always (a Pareto sweep's ε moves its bound, built once);
        the attained form's where the other side is bounded."""
        quantity = get_quantity(self.spec.name)
        out = [(self.name, q.quantities[self.spec.key])]
        if bounded_sides(self.spec) - {quantity.natural_side()}:
            out.append((self.name + ATTAINED, q.attained[self.spec.key]))
        return out

    def row_bounds(self, problem, row, tightening_deg=0.0):
        """The row's side of the bound, in the NLP's figure (a decreasing figure, cos²μ of
        an angle, turns a lower bound into an upper one)."""
        quantity = get_quantity(self.spec.name)
        lower, upper = self.bounds(problem)
        natural = quantity.natural_side()
        side = natural if not row.split("[", 1)[0].endswith(ATTAINED) else \
            ("lower" if natural == "upper" else "upper")
        value = lower if side == "lower" else upper
        if quantity.figure_worst != quantity.worst:
            side = "lower" if side == "upper" else "upper"
        figure = quantity.to_figure(value)
        return (figure, math.inf) if side == "lower" else (-math.inf, figure)

    def bounds(self, problem, tightening_deg=0.0):
        """The bound of ``problem``'s spec of this key (a Pareto point's ε moves it without
        rebuilding the NLP)."""
        spec = next((s for s in problem.quantity_bounds if s.key == self.spec.key),
                    self.spec)
        return spec.lower, spec.upper

    def tolerance(self, m):
        """Relative to the value: the NLP holds the bound to IPOPT's tolerance."""
        return quantity_tolerance(self.value(m))

    def quantity_bound(self, problem):
        return self.spec

    def without(self, problem):
        others = tuple(s for s in problem.quantity_bounds if s.key != self.spec.key)
        return problem.with_quantity_bounds(others)

    def key(self, problem):
        """``constraints.ratio.upper``: the side where one is given alone."""
        sides = bounded_sides(self.spec)
        return f"constraints.{self.spec.name}" + (f".{next(iter(sides))}" if len(sides) == 1
                                                  else "")


class SectionConstraint(Constraint):
    """A constraint a problem-file section contributes (e.g. the driveline's speed limit):
    the section gives the symbolic rows from the peak output speed and checks the design."""

    def __init__(self, key: str, section, problem):
        self.key_name, self.section, self.problem = key, section, problem
        self.name = key

    def rows(self, q):
        return [(f"{self.key_name}.{name}", g) for name, g in
                self.section.solve_constraints(self.problem, q.peak_speed)]

    def bounds(self, problem, tightening_deg=0.0):
        return 0.0, math.inf

    def key(self, problem):
        return self.key_name

    def violation(self, problem, m):
        return math.inf if self.section.verify(problem, m.evaluation) else -math.inf

    def message(self, problem, m) -> str:
        return self.section.verify(problem, m.evaluation) or ""


def constraints_of(problem) -> list[Constraint]:
    """Every constraint of a problem: the general ones, the mechanism's, the sections'."""
    out: list[Constraint] = [TransmissionAngle(), RatioFloor()]
    out += objective_of(problem).constraints(problem)
    out += problem.model.criteria(problem.constraints, problem.options)
    out += [QuantityConstraint(spec) for spec in problem.quantity_bounds]
    for key, section in problem.sections.items():
        if hasattr(section, "solve_constraints"):
            out.append(SectionConstraint(key, section, problem))
    return out


# --------------------------------------------------------------------------- objectives
class Objective:
    """What the NLP minimises, and the key that ranks verified designs (lower is better)."""

    name: str = ""
    #: how the reports write the objective (in d OBJECTIVE / d bound)
    symbol: str = ""
    #: ``objective:`` keys this objective needs besides ``minimize``
    requires: tuple[str, ...] = ()

    def expression(self, q):
        raise NotImplementedError

    def constraints(self, problem) -> list[Constraint]:
        """Constraints that come with this objective (e.g. the ripple cap of the largest
        ratio)."""
        return []

    def rank(self, delta: float, ratio: float) -> float:
        """The ranking key of a design with worst ripple ``delta`` and ratio ``ratio``."""
        raise NotImplementedError

    def key(self, m) -> float:
        """The ranking key of a measured design (:class:`Measured`, exact) or of the
        screening's sampled arrays (the same names)."""
        return self.rank(m.worst_ripple, m.ratio)

    def result_key(self, result) -> float:
        """The ranking key of a count's optimum (a PhaseResult)."""
        return self.rank(result.delta, result.ratio)

    def per_nlp_unit(self, m) -> float:
        """The objective's units per unit of the NLP's objective at the measured design
        ``m``: what IPOPT's multipliers are scaled by to give d objective / d bound."""
        return 1.0


class LeastRipple(Objective):
    """The worst δ over the listed eccentricities."""

    name = "ripple"
    symbol = "δ"

    def expression(self, q):
        return q.worst_ripple

    def rank(self, delta, ratio):
        return delta


class LargestRatio(Objective):
    """The ratio, under the ripple cap; the worst δ breaks ties lexicographically."""

    name = "-ratio"
    symbol = "(-ratio)"

    def expression(self, q):
        return -q.ratio + RIPPLE_TIE_BREAK * q.worst_ripple

    requires = ("max_ripple",)

    def constraints(self, problem):
        return [RippleCap()]

    def rank(self, delta, ratio):
        return -ratio


class LeastCount(LeastRipple):
    """The least admissible count whose least δ meets the ripple cap (``minimize: phases``,
    :mod:`optdesign.solver.least_count`). Each count is solved for its least δ, the secondary
    objective (the atlas's question per cell), so within a count designs rank by δ and the
    cap is one of the constraints they are checked against."""

    name = "phases"
    requires = ("max_ripple",)

    def constraints(self, problem):
        return [RippleCap()]


class QuantityObjective(Objective):
    """The worst of a quantity over the listed eccentricities, least (``minimize: NAME``)
    or largest (``minimize: -NAME``); the worst δ breaks ties, as for the largest ratio. The
    NLP reads the quantity's natural form when the objective pushes it towards its natural
    side (the least housing radius, the largest least swing) and its attained form otherwise
    (:mod:`optdesign.solver.nlp`), each in its NLP figure (cos²μ for the angle)."""

    quantity: str = ""
    maximize: bool = False

    @property
    def sign(self) -> float:
        return -1.0 if self.maximize else 1.0

    @property
    def natural(self) -> bool:
        """Whether the objective pushes the quantity towards its natural side."""
        return self.maximize == (get_quantity(self.quantity).worst == "min")

    def expression(self, q):
        quantity = get_quantity(self.quantity)
        figure = (q.quantities if self.natural else q.attained)[self.quantity]
        increasing = 1.0 if quantity.figure_worst == quantity.worst else -1.0
        return self.sign * increasing * figure + RIPPLE_TIE_BREAK * q.worst_ripple

    def key(self, m):
        return self.sign * m.quantities[self.quantity]

    def result_key(self, result):
        return self.sign * result.quantities["values"][self.quantity]


class LargestLeastAngle(QuantityObjective):
    """The largest least transmission angle over the turn and the listed eccentricities
    (``minimize: -transmission_angle``): the NLP minimises an epigraph z >= cos²μ at every
    tracked extreme of cos μ, the least angle's cos² (:mod:`optdesign.solver.nlp`); the
    exact key is the least angle itself (degrees, negated); the worst δ breaks ties."""

    quantity = "transmission_angle"
    maximize = True
    name = "-transmission_angle"
    symbol = "(-μ_min)"

    def per_nlp_unit(self, m) -> float:
        """Degrees of −μ_min per unit of cos²μ_min: d cos²μ / d(−μ) = sin 2μ per radian."""
        slope = math.sin(2 * math.radians(m.quantities[self.quantity])) * math.pi / 180.0
        return 1.0 / slope if slope > 0 else math.nan


def _quantity_objectives() -> dict[str, type[Objective]]:
    """``minimize: NAME`` (least) and ``minimize: -NAME`` (largest) for every quantity."""
    return _objectives_of(known())


@lru_cache(maxsize=8)
def _objectives_of(names: tuple[str, ...]) -> dict[str, type[Objective]]:
    out: dict[str, type[Objective]] = {}
    for name in names:
        q = get_quantity(name)
        for maximize in (False, True):
            key = f"-{name}" if maximize else name
            out[key] = type(f"Objective_{'largest' if maximize else 'least'}_{name}",
                            (QuantityObjective,),
                            {"quantity": name, "maximize": maximize, "name": key,
                             "symbol": f"(-{name})" if maximize else name,
                             "__doc__": f"{'Largest' if maximize else 'Least'} {q.label}."})
    return out


#: the objectives ``objective.minimize`` may name besides the quantities' own
OBJECTIVES: dict[str, type[Objective]] = {"ripple": LeastRipple, "-ratio": LargestRatio,
                                          "-transmission_angle": LargestLeastAngle,
                                          "phases": LeastCount}


def objectives() -> dict[str, type[Objective]]:
    """Every name ``objective.minimize`` takes: :data:`OBJECTIVES` and two per quantity, its
    least and its largest (the registry as it is now)."""
    return OBJECTIVES | {k: v for k, v in _quantity_objectives().items() if k not in OBJECTIVES}


def objective_of(problem) -> Objective:
    return objectives()[problem.objective.minimize]()

"""What a front trades the ripple against: ``pareto: {against: QUANTITY}``, the ratio by default.

The sweep works on the *gain* g = sign·value of the quantity, which it maximises against δ:
the ratio is its own gain (larger is better), a housing radius counts negatively (smaller is
better). Every ε point is the least δ subject to g >= ε, the second end of a count's front the
largest gain (``largest_ratio``; ``best_housing_radius``), and the indicators, the refinement
and the report see (δ, g) pairs, so a front of ripple against housing size is swept, refined
and judged exactly as the ripple against the ratio. Tables and figures show the quantity in
its own units.
"""
from __future__ import annotations

from dataclasses import dataclass

from optdesign.quantities import TurnQuantity, get_quantity, known
from optdesign.quantities.bounds import QuantityBound

DEFAULT = "ratio"


def choices() -> tuple[str, ...]:
    """The quantities a front can be swept against: the ratio and every turn quantity (those
    the NLP holds under a bound and can optimise)."""
    return (DEFAULT,) + tuple(n for n in known() if isinstance(get_quantity(n), TurnQuantity))


@dataclass(frozen=True)
class Axis:
    name: str = DEFAULT

    @property
    def quantity(self):
        return get_quantity(self.name)

    @property
    def sign(self) -> float:
        """+1 where a larger value is better (the ratio, the swing), -1 where a smaller is."""
        return 1.0 if self.quantity.worst == "min" else -1.0

    @property
    def is_ratio(self) -> bool:
        return self.name == DEFAULT

    @property
    def end(self) -> str:
        """The journal's tag of a count's largest-gain end."""
        return "largest_ratio" if self.is_ratio else f"best_{self.name}"

    @property
    def objective(self) -> str:
        """``objective.minimize`` of the largest-gain end."""
        return "-ratio" if self.is_ratio else ("-" if self.sign > 0 else "") + self.name

    @property
    def label(self) -> str:
        return self.quantity.label

    @property
    def unit(self) -> str:
        return self.quantity.unit

    def value_of(self, record: dict):
        """The quantity's exact value in a record (None when it has none)."""
        if self.is_ratio:
            return record.get("ratio")
        return ((record.get("quantities") or {}).get("values") or {}).get(self.name)

    def gain_of(self, record: dict):
        value = self.value_of(record)
        return None if value is None else self.sign * value

    def value(self, gain):
        """The quantity's value of a gain (or of an ε, a bound on the gain)."""
        return None if gain is None else self.sign * gain

    def bound(self, epsilon: float) -> QuantityBound:
        """g >= ε as a bound on the quantity."""
        return QuantityBound(self.name, lower=epsilon) if self.sign > 0 else \
            QuantityBound(self.name, upper=-epsilon)


def axis_of(problem) -> Axis:
    section = problem.sections.get("pareto")
    return Axis(getattr(section, "against", DEFAULT) or DEFAULT)


def with_axis(problem):
    """The problem with the axis's quantity among its bounds (unbounded), so the NLP carries
    the row each ε point bounds; the ratio's row is always there."""
    from dataclasses import replace

    axis = axis_of(problem)
    if axis.is_ratio or any(s.name == axis.name and s.at is None
                            for s in problem.quantity_bounds):
        return problem
    specs = problem.quantity_bounds + (QuantityBound(axis.name),)
    return problem.with_quantity_bounds(specs)

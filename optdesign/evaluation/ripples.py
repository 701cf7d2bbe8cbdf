"""One δ, named: which ripple a figure, a page or a line shows, in the same words everywhere.

A design's ripple δ = (ω_max − ω_min)/ω_avg (Sharkov & Kalinin 2022, eq. 9; Artobolevsky's
coefficient of velocity fluctuation) changes with the crank eccentricity e, so a bare "δ" is
ambiguous: the problem's δ is the worst over the listed eccentricities (or over the regulation
interval), and it falls at one of them. Every output that shows a δ labels it with
:func:`ripple_label`:

* ``δ (midrange, worst over e = 1, 0.3, at e = 0.3) = 0.081097``: the worst over the listed
  eccentricities, and where it falls;
* ``δ (midrange, worst over e in [0.2, 1], at e = 0.3471) = 0.140214``: the worst over a
  regulation interval, and where it falls;
* ``δ (midrange, at e = 1) = 0.079003``: at one named eccentricity;
* ``δ (midrange, worst over e = 1) = 0.103975``: the problem's δ when it lists one
  eccentricity.
"""
from __future__ import annotations

from dataclasses import dataclass


def _e(value: float) -> str:
    return f"{value:g}" if round(value, 4) == value else f"{value:.4f}"


def ripple_label(definition: str, at: float | None, over=(), interval=None) -> str:
    """The words naming a δ: its definition (midrange | mean), what it is the worst over (the
    listed eccentricities ``over``, or the regulation ``interval`` (lower, upper)) and the
    eccentricity ``at`` which it falls (or is read, when it is the worst over nothing)."""
    where = [definition]
    if interval is not None:
        where.append(f"worst over e in [{_e(interval[0])}, {_e(interval[1])}]")
    elif over:
        where.append(f"worst over e = {', '.join(_e(e) for e in over)}")
    if at is not None:
        where.append(f"at e = {_e(at)}")
    return f"δ ({', '.join(where)})"


@dataclass(frozen=True)
class Ripple:
    """A δ and what it is: its value, definition, the eccentricity it falls at, and what it
    is the worst over (``over``: the listed eccentricities; ``interval``: (lower, upper))."""

    value: float
    definition: str
    at: float | None
    over: tuple[float, ...] = ()
    interval: tuple[float, float] | None = None

    @property
    def label(self) -> str:
        return ripple_label(self.definition, self.at, self.over, self.interval)

    def text(self, digits: int = 6) -> str:
        """``label = value`` with ``digits`` decimals."""
        return f"{self.label} = {self.value:.{digits}f}"

    @property
    def eccentricity(self) -> float | None:
        """Where the δ falls (the one listed e when it is the worst over one)."""
        return self.at if self.at is not None or len(self.over) != 1 else self.over[0]

    def to_dict(self) -> dict:
        return {"delta": self.value, "eccentricity": self.eccentricity, "label": self.label}


@dataclass(frozen=True)
class Ripples:
    """The problem's δ of a design (``worst``) and its δ at each eccentricity shown
    (``each``: the listed ones, and the interval's worst)."""

    worst: Ripple
    each: tuple[Ripple, ...]

    def to_dict(self) -> dict:
        return {"worst": self.worst.to_dict(), "each": [r.to_dict() for r in self.each]}


def named_ripples(definition: str, per_e: dict, interval=None,
                  interval_worst: tuple[float, float] | None = None) -> Ripples:
    """The :class:`Ripples` of δ at the listed eccentricities ``per_e`` ({e: δ}, in the
    problem's order) and, with a regulation ``interval``, the worst over it
    ``interval_worst`` (e, δ)."""
    each = [Ripple(float(d), definition, float(e)) for e, d in per_e.items()]
    if interval is not None and interval_worst is not None \
            and all(r.at != interval_worst[0] for r in each):
        each.append(Ripple(float(interval_worst[1]), definition, float(interval_worst[0])))
    top = max(each, key=lambda r: r.value)
    if interval is not None:
        worst = Ripple(top.value, definition, top.at, interval=tuple(interval))
    elif len(per_e) == 1:           # one listed e: "worst over e = 1", where it falls is plain
        worst = Ripple(top.value, definition, None, (top.at,))
    else:
        worst = Ripple(top.value, definition, top.at, tuple(float(e) for e in per_e))
    return Ripples(worst, tuple(each))


def ripples_of_evaluation(problem, ev) -> Ripples:
    """The :class:`Ripples` of an exact evaluation ``ev``
    (:func:`optdesign.evaluation.figures.evaluate_problem`) of a design of ``problem``."""
    definition = problem.objective.ripple
    per_e = {e: ev.at(e).figures[problem.stroke].ripple(definition)
             for e in problem.eccentricities}
    worst = None
    if ev.worst is not None and ev.worst_definition == definition:
        worst = (ev.worst.eccentricity, ev.worst.delta)
    return named_ripples(definition, per_e, problem.eccentricity_range, worst)


def ripples_of_quantities(definition: str, quantities: dict, interval=None) -> Ripples | None:
    """The :class:`Ripples` read off a result's ``quantities``
    (:func:`optdesign.quantities.design_quantities`: ``per_eccentricity``, each with its
    ``ripple``, and the ``interval``'s worst); None when they hold no ripple."""
    rows = [r for r in (quantities or {}).get("per_eccentricity", []) if "ripple" in r]
    if not rows:
        return None
    per_e = {r["eccentricity"]: r["ripple"] for r in rows}
    searched = (quantities or {}).get("interval", {}).get("ripple")
    worst = (searched["eccentricity"], searched["value"]) if searched else None
    return named_ripples(definition, per_e, interval, worst)


def design_ripples(problem, values: dict | None = None) -> Ripples | None:
    """The :class:`Ripples` of the problem's design (or ``values``), evaluated exactly at the
    listed eccentricities (and over the regulation interval); None when it does not
    assemble."""
    from optdesign.evaluation.figures import evaluate_problem

    ev = evaluate_problem(problem, values)
    return ripples_of_evaluation(problem, ev) if ev.assembles else None

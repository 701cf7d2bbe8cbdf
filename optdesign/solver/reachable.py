"""How far out of reach an infeasible bound is: the nearest value any design in the bounds
reaches.

When no start of a count meets the problem, a constraint that may bind (the ratio floor, the
transmission angle, a ripple cap, a bound on a quantity; the one IPOPT names first) is dropped
and its own figure made the objective of the same NLP, every other constraint kept: the largest ratio, the largest
least transmission angle, the least ripple, the least housing radius (the largest least swing)
any design in the bounds reaches. Below (above) the file's bound, the count is infeasible by
that much; at or beyond it, a design that meets the bound exists and more starts may find it.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, replace

from optdesign.quantities import get_quantity

#: the ripple cap of the largest-ratio solve that finds the largest reachable ratio
LOOSE_RIPPLE = 10.0


@dataclass(frozen=True)
class Reach:
    """The nearest value of ``constraint``'s figure any design in the bounds reaches."""

    constraint: str             # the binding constraint, as the result names it
    figure: str                 # what it bounds, in words
    bound: float                # the file's bound
    value: float                # the nearest value reached (verified exactly)
    side: str                   # "largest" or "least": which way the bound asks for more
    unit: str

    @property
    def out_of_reach(self) -> bool:
        return self.value < self.bound if self.side == "largest" else self.value > self.bound

    def text(self, count_name: str, count: int) -> str:
        unit = "" if self.unit in ("", "-") else f" {self.unit}"
        verb = "at least" if self.side == "largest" else "at most"
        return (f"{self.constraint} {verb} {self.bound:g}{unit} is out of reach: the "
                f"{self.side} {self.figure} any design in the bounds reaches with {count} "
                f"{count_name} is {self.value:.6g}{unit} (verified), under every other "
                f"constraint")

    def to_dict(self) -> dict:
        return asdict(self)


def candidates(problem, binding: str | None) -> list[str]:
    """The constraints that may make the problem infeasible, the one IPOPT found binding
    first: the ratio floor, the transmission angle, the ripple cap and every bound on a
    quantity at its worst."""
    out = [(binding or "").split("[", 1)[0]]
    obj, c = problem.objective, problem.constraints
    out += ["min_ratio"] if obj.min_ratio > 0 else []
    out += ["transmission_angle"] if c.min_transmission_angle_deg > 0 else []
    out += ["max_ripple"] if obj.max_ripple is not None else []
    out += [s.key for s in c.quantities if s.at is None]
    return list(dict.fromkeys(n for n in out if n))


def relaxed(problem, name: str):
    """(the problem with constraint ``name`` dropped and its figure the objective, how to
    read the figure off the variant's PhaseResult, the figure in words, the side, the file's
    bound, the unit), or None where no objective measures that figure."""
    obj, c = problem.objective, problem.constraints
    plain = replace(obj, robust="none")
    if name == "min_ratio" and obj.min_ratio > 0:
        variant = replace(plain, minimize="-ratio", min_ratio=0.0, max_ripple=LOOSE_RIPPLE)
        return (replace(problem, objective=variant), lambda r: r.ratio, "ratio", "largest",
                obj.min_ratio, "-")
    if name == "transmission_angle" and c.min_transmission_angle_deg > 0:
        variant = replace(plain, minimize="-transmission_angle",
                          max_ripple=obj.max_ripple if obj.minimize == "-ratio" else None)
        return (replace(problem, objective=variant,
                        constraints=replace(c, min_transmission_angle_deg=0.0)),
                lambda r: r.min_transmission_angle_deg, "least transmission angle",
                "largest", c.min_transmission_angle_deg, "deg")
    if name == "max_ripple" and obj.max_ripple is not None:
        variant = replace(plain, minimize="ripple", max_ripple=None)
        return (replace(problem, objective=variant), lambda r: r.delta, "ripple δ", "least",
                obj.max_ripple, "-")
    spec = next((s for s in c.quantities if s.key == name and s.at is None), None)
    if spec is None or spec.name in ("ratio", "ripple"):
        return None
    q = get_quantity(spec.name)
    key = spec.name if q.worst == "max" else f"-{spec.name}"
    others = tuple(s for s in c.quantities if s.key != spec.key)
    bound = spec.upper if q.worst == "max" else spec.lower
    return (replace(problem, objective=replace(plain, minimize=key),
                    constraints=replace(c, quantities=others)),
            lambda r: r.quantities["values"][spec.name], spec.name,
            "least" if q.worst == "max" else "largest", bound, q.unit)


#: relaxed solves tried at most: each costs a multi-start solve, and one that is infeasible
#: too costs a failed one
MAX_RELAXED = 2


def reach_of(problem, count: int, binding: str | None, solve_phase) -> Reach | None:
    """The first of :func:`candidates` whose nearest reachable value lies beyond its bound
    (``solve_phase`` solves each relaxed problem, without asking this again; at most
    :data:`MAX_RELAXED` of them); else the first one's within its bound (a design exists:
    more starts may find it); None where none can be told."""
    within, tried = None, 0
    for name in candidates(problem, binding):
        found = relaxed(problem, name)
        if found is None:
            continue
        if tried == MAX_RELAXED:
            break
        tried += 1
        variant, read, figure, side, bound, unit = found
        best = solve_phase(variant, count, workers=1, explain=False)
        if best.status != "optimal":
            continue
        reach = Reach(name, figure, float(bound), float(read(best)), side, unit)
        if reach.out_of_reach:
            return reach
        within = within or reach
    return within

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

import math
from dataclasses import asdict, dataclass, replace

from optdesign.quantities import get_quantity
from optdesign.quantities.criteria import constraints_of, objectives
from optdesign.solver.verify import verify

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
    #: the problem file's key of the bound, as the user wrote it
    key: str = ""
    #: the design that reaches ``value`` (every length and the count), verified exactly
    design: dict | None = None

    @property
    def out_of_reach(self) -> bool:
        return self.value < self.bound if self.side == "largest" else self.value > self.bound

    def text(self, count_name: str, count: int) -> str:
        unit = "" if self.unit in ("", "-") else f" {self.unit}"
        verb = "at least" if self.side == "largest" else "at most"
        return (f"{self.key or self.constraint} {verb} {self.bound:g}{unit} is out of reach: the "
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
    """(the problem with constraint ``name`` dropped and its figure the objective, the
    figure read off a :class:`~optdesign.quantities.criteria.Measured` design, the figure in
    words, the side, the file's bound, the unit), or None where no objective measures that
    figure. Every other constraint is kept (a ripple cap under the largest ratio too)."""
    obj, c = problem.objective, problem.constraints
    plain = replace(obj, robust="none")
    if name == "min_ratio" and obj.min_ratio > 0:
        cap = obj.max_ripple if obj.minimize == "-ratio" else LOOSE_RIPPLE
        variant = replace(plain, minimize="-ratio", min_ratio=0.0, max_ripple=cap)
        return (replace(problem, objective=variant), lambda m: m.ratio, "ratio", "largest",
                obj.min_ratio, "-")
    if name == "transmission_angle" and c.min_transmission_angle_deg > 0:
        variant = replace(plain, minimize="-transmission_angle",
                          max_ripple=obj.max_ripple if obj.minimize == "-ratio" else None)
        return (replace(problem, objective=variant,
                        constraints=replace(c, min_transmission_angle_deg=0.0)),
                lambda m: m.min_angle_deg, "least transmission angle", "largest",
                c.min_transmission_angle_deg, "deg")
    if name == "max_ripple" and obj.max_ripple is not None:
        variant = replace(plain, minimize="ripple", max_ripple=None)
        return (replace(problem, objective=variant), lambda m: m.worst_ripple, "ripple δ",
                "least", obj.max_ripple, "-")
    spec = next((s for s in c.quantities if s.key == name and s.at is None), None)
    if spec is None:
        return None
    q = get_quantity(spec.name)
    sides = [side for side in ("lower", "upper") if math.isfinite(getattr(spec, side))]
    if len(sides) != 1 or sides[0] != q.natural_side():
        return None
    key = spec.name if q.worst == "max" else f"-{spec.name}"
    if key not in objectives():
        return None
    others = tuple(s for s in c.quantities if s.key != spec.key)
    bound = spec.upper if q.worst == "max" else spec.lower
    return (replace(problem, objective=replace(plain, minimize=key),
                    constraints=replace(c, quantities=others)),
            lambda m: m.quantities[spec.key], spec.name,
            "least" if q.worst == "max" else "largest", bound, q.unit)


#: relaxed solves tried at most: each costs a multi-start solve, and one that is infeasible
#: too costs a failed one
MAX_RELAXED = 2


def reach_of(problem, count: int, binding: str | None, solve_phase, workers: int = 1,
             known=()) -> Reach | None:
    """The first of :func:`candidates` whose nearest reachable value lies beyond its bound
    (``solve_phase`` solves each relaxed problem, without asking this again; at most
    :data:`MAX_RELAXED` of them); else the first one's within its bound (a design exists:
    it meets every constraint, and the solve polishes from it); None where none can be told.

    The value is the best of the relaxed solve's optimum and of every design in ``known``
    (designs the solve evaluated, and the user's) that meets every other constraint, each
    verified exactly under ``problem``: a verdict never contradicts a design the tool has
    seen."""
    within, tried = None, 0
    for name in candidates(problem, binding):
        found = relaxed(problem, name)
        if found is None:
            continue
        if tried == MAX_RELAXED:
            break
        tried += 1
        variant, read, figure, side, bound, unit = found
        best = solve_phase(variant, count, workers=workers, explain=False)
        designs = ([best.design] if best.status == "optimal" else []) + list(known)
        reach = None
        for design in designs:
            ver = verify(problem, design)
            if ver.measured is None or set(ver.violations) - {name}:
                continue
            value = float(read(ver.measured))
            better = reach is None or (value > reach.value if side == "largest"
                                       else value < reach.value)
            if better:
                reach = Reach(name, figure, float(bound), value, side, unit,
                              _key_of(problem, name), dict(design))
        if reach is None:
            continue
        if reach.out_of_reach:
            return reach
        within = within or reach
    return within


def _key_of(problem, name: str) -> str:
    """The problem file's key of constraint ``name``, as the user wrote it."""
    return next((c.key(problem) for c in constraints_of(problem) if c.name == name), name)

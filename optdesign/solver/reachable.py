"""How far out of reach an infeasible bound is: the nearest value any design in the bounds
reaches.

When no start of a count meets the problem, a bound that may bind (the ratio floor, the
transmission angle, a ripple cap, a bound on a quantity, on either side; the one IPOPT names
first) is dropped and its quantity, pushed towards the bound, made the objective of the same
problem, every other constraint kept: the largest ratio, the least ratio under a cap, the
largest least transmission angle, the least ripple, the least housing radius any design in the
bounds reaches. Beyond the file's bound, the count is infeasible by that much (the relaxed
optimum verified exactly, and no design the solve has seen doing better); at or within it, the
relaxed optimum meets every constraint and the solve polishes from it.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, replace

from optdesign.quantities import get_quantity
from optdesign.quantities.criteria import bounded_sides, constraints_of, objectives, value_of
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
    first: every constraint that holds one side of a quantity at its worst (the older keys
    read as quantity bounds: the ratio floor, the transmission angle, the ripple cap)."""
    out = [(binding or "").split("[", 1)[0]]
    for criterion in constraints_of(problem):
        spec = criterion.quantity_bound(problem)
        if spec is not None and spec.at is None:
            out.append(criterion.name)
    return list(dict.fromkeys(n for n in out if n))


def relaxed(problem, name: str, side: str | None = None):
    """(the problem with constraint ``name`` dropped and its quantity pushed towards the
    bound's ``side`` as the objective, the figure read off a
    :class:`~optdesign.quantities.criteria.Measured` design, the figure in words, the side,
    the file's bound, the unit, the bound's file key), or None where the constraint bounds no
    quantity at its worst. A band (both sides bounded) is dropped whole and pushed towards the
    ``side`` given: a band whose upper side the least value reachable lies beyond is out of
    reach as surely as a cap. Every other constraint is kept: one that came with the
    objective (the ripple cap of the largest ratio) becomes a bound of its own."""
    criterion, spec = _bound_of(problem, name)
    if spec is None or spec.at is not None:
        return None
    sides = bounded_sides(spec)
    if side is None and len(sides) == 1:
        side, = sides
    if side not in sides:
        return None
    quantity = get_quantity(spec.name)
    variant = criterion.without(problem)
    goal = f"-{spec.name}" if side == "lower" else spec.name
    # every other bound stays, held by whichever criterion the new objective gives it (the
    # ripple's cap of a largest ratio becomes a bound on the ripple)
    variant = replace(variant, objective=replace(variant.objective, robust="none",
                                                 minimize=goal))
    if "max_ripple" in objectives()[goal].requires and variant.constraints.max_ripple is None:
        variant = variant.with_limit("ripple", "upper", LOOSE_RIPPLE)
    bound = spec.lower if side == "lower" else spec.upper
    key = criterion.key(problem) + (f".{side}" if len(sides) > 1 else "")
    return (variant, lambda m: value_of(problem, spec, m.evaluation),
            quantity.words or spec.name, "largest" if side == "lower" else "least", bound,
            quantity.unit, key)


def sides_to_relax(problem, name: str, checked=()) -> list[str | None]:
    """The sides of constraint ``name``'s bound to relax, in turn: its one side (None), or
    a band's two, the side more of the ``checked`` designs (verifications) miss first, the
    upper one on a tie."""
    _, spec = _bound_of(problem, name)
    if spec is None or len(bounded_sides(spec)) != 2:
        return [None]
    missed = {"lower": 0, "upper": 0}
    for ver in checked:
        value = value_of(problem, spec, ver.measured.evaluation)
        missed["lower"] += value < spec.lower
        missed["upper"] += value > spec.upper
    return sorted(("upper", "lower"), key=lambda side: -missed[side])


def checked_designs(check, known) -> list:
    """The exact checks (``check``: a design's verification) of the first of ``known`` (the
    user's design) and of its last :data:`KNOWN_CHECKED` - 1 (where the polishes ended),
    those that assemble."""
    designs = list(known)
    picks = designs[:1] + designs[1:][-(KNOWN_CHECKED - 1):]
    return [ver for ver in map(check, picks) if ver.measured is not None]


def _bound_of(problem, name: str):
    """(constraint ``name`` of ``problem``, the bound on a quantity it holds), each None
    where there is none."""
    criterion = next((c for c in constraints_of(problem) if c.name == name), None)
    return criterion, criterion.quantity_bound(problem) if criterion is not None else None


def _checker(problem):
    """``verify(problem, design)``, each design verified once (the verdict reads the known
    designs twice: for the bounds they break, and as candidates for the reachable value)."""
    done = {}

    def check(design):
        key = tuple(sorted(design.items()))
        if key not in done:
            done[key] = verify(problem, design)
        return done[key]
    return check


def ranked_candidates(problem, binding: str | None, checked) -> list[str]:
    """:func:`candidates`, those more of the ``checked`` designs break first (IPOPT's
    binding constraint first among equals): the bound the designs the solve has seen miss is
    the one to relax, where IPOPT's last word may name another."""
    missed = {}
    for ver in checked:
        for name in ver.violations:
            missed[name] = missed.get(name, 0) + 1
    return sorted(candidates(problem, binding), key=lambda name: -missed.get(name, 0))


#: known designs checked for the bounds they break: the user's and where the last polishes
#: ended
KNOWN_CHECKED = 6


#: relaxed solves tried at most: each costs a multi-start solve, and one that is infeasible
#: too costs a failed one
MAX_RELAXED = 2
#: polishes a relaxed solve may take at most (its screening's best basins and lines)
RELAXED_STARTS = 4
#: a bound beyond the first relaxed polish's value by more than this share of the bound (or
#: of the value, whichever is larger) is far out of reach: that polish alone is the verdict's
#: search. Nearer, the search goes on through :data:`RELAXED_STARTS` basins, where a second
#: basin could still reach the bound
FAR_BEYOND = 0.25


def reach_of(problem, count: int, binding: str | None, solve_phase, workers: int = 1,
             known=()) -> Reach | None:
    """The first of :func:`ranked_candidates` whose nearest reachable value lies beyond its bound
    (``solve_phase`` solves each relaxed problem, without asking this again; at most
    :data:`MAX_RELAXED` of them); else the first one's within its bound (a design exists:
    it meets every constraint, and the solve polishes from it); None where none can be told.

    The value is the best of the relaxed solve's optimum and of every design in ``known``
    (designs the solve evaluated, and the user's) that meets every other constraint, each
    verified exactly under ``problem``: a verdict never contradicts a design the tool has
    seen."""
    within, tried = None, 0
    check = _checker(problem)
    checked = checked_designs(check, known)
    tries = ((name, side) for name in ranked_candidates(problem, binding, checked)
             for side in sides_to_relax(problem, name, checked))
    for name, band_side in tries:
        found = relaxed(problem, name, band_side)
        if found is None:
            continue
        if tried == MAX_RELAXED:
            break
        tried += 1
        variant, read, figure, side, bound, unit, key = found
        # a verdict's search: the relaxed problem's best basin first, then (unless the bound
        # lies far beyond it) its next basins, never every start
        reach = None
        for starts in (1, RELAXED_STARTS):
            searched = replace(variant, solver=replace(
                variant.solver, starts=min(variant.solver.starts, starts)))
            best = solve_phase(searched, count, workers=workers, explain=False)
            # the known designs are verified once, with the first pass
            designs = ([best.design] if best.status == "optimal" else []) + \
                (list(known) if reach is None else [])
            reach = _nearest(check, name, designs, read, reach,
                             (figure, float(bound), side, unit, key))
            if reach is None or not reach.out_of_reach or _far(reach) or \
                    variant.solver.starts <= starts:
                break
        if reach is None:
            continue
        if reach.out_of_reach:
            return reach
        within = within or reach
    return within


def _nearest(check, name: str, designs, read, reach: Reach | None, what) -> Reach | None:
    """The nearest to the bound of ``reach`` and ``designs`` that meet every constraint but
    ``name``, each verified exactly under the problem (``check``)."""
    figure, bound, side, unit, key = what
    for design in designs:
        ver = check(design)
        if ver.measured is None or set(ver.violations) - {name}:
            continue
        value = float(read(ver.measured))
        if reach is None or (value > reach.value if side == "largest" else value < reach.value):
            reach = Reach(name, figure, bound, value, side, unit, key, dict(design))
    return reach


def _far(reach: Reach) -> bool:
    """Whether ``reach``'s bound lies :data:`FAR_BEYOND` its value."""
    return abs(reach.bound - reach.value) > FAR_BEYOND * max(abs(reach.bound),
                                                             abs(reach.value))

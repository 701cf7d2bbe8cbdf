"""An oracle for the solver's verdicts: random problems, each verdict set against a brute-force
sample of its box judged by the exact evaluator.

A problem is drawn from a :class:`Draw` (a mechanism from a shipped problem, its box widened to
span one to six decades, with or without initial values, a count, a stroke, random lower and
upper bounds on random quantities, ratio bands and caps among them, and an objective minimised
or maximised); its bounds are set at quantiles of the quantity over the box, so that some bind,
some are slack and some are out of reach. :func:`sample` draws :data:`SAMPLE` designs of the
box (uniformly, or log-uniformly on a range of more than two decades), ranks them by the
vectorised sampled evaluator and checks the best :data:`CHECKED` and :data:`RANDOM` others,
and the file's own design, with the exact evaluator. :func:`judge` lists the false claims:

* ``optimal`` whose design the exact evaluator finds infeasible, or that a checked design of the
  sample beats on the problem's own objective (beyond :data:`KEY_TOL`);
* ``infeasible`` or ``failed`` where a checked design of the sample meets every constraint.

``benchmarks/solve_oracle.py`` runs a large draw and writes its table; ``tests/solve/
test_oracle.py`` runs a small one through hypothesis.
"""
from __future__ import annotations

import copy
import math
import time
import warnings
from dataclasses import dataclass, field

import numpy as np
import yaml

from optdesign.problem.loader import problem_from_dict
from optdesign.quantities.criteria import objective_of
from optdesign.solver import solve, verify
from optdesign.solver.screening import sampled_scores, spread

ROOT = __import__("pathlib").Path(__file__).resolve().parents[1]

#: the shipped problem each mechanism's draws start from
BASES = {"fourbar_converter": "sharkov2022_disc", "slotted_lever": "vergov_solve",
         "pulse_reducer": "pulse_reducer_solve"}
#: quantities a bound or an objective may name, per mechanism
QUANTITIES = {
    "fourbar_converter": ("ratio", "ripple", "transmission_angle", "peak_speed",
                          "housing_radius", "swing", "peak_acceleration"),
    "slotted_lever": ("ratio", "ripple", "peak_speed", "swing", "peak_acceleration"),
    "pulse_reducer": ("ratio", "ripple", "peak_speed", "peak_acceleration"),
}
#: designs of the box sampled, the best of them by the sampled evaluator checked exactly, and
#: others at random
SAMPLE, CHECKED, RANDOM = 4096, 32, 16
#: a sampled design beats an optimum when its exact key is lower by more than this (relative,
#: at least absolute 1e-6): the solve's optimum is verified to the check's tolerances
KEY_TOL = 1e-6


@dataclass(frozen=True)
class Draw:
    """The random choices of one problem (all in [0, 1) or small integers)."""

    mechanism: str
    decades: float                    # the box spans 10**decades on each free length
    centre: float                     # where the widened box sits, in [0, 1)
    initial: bool                     # keep the file's initial values
    count: int                        # index into the base's admissible counts (or ``counts``)
    stroke: int                       # index into the mechanism's strokes
    bounds: tuple = ()                # (quantity index, side: lower|upper|both, quantile)
    objective: tuple = ("ripple", False)    # (quantity, maximise)
    seed: int = 0
    #: the counts ``count`` indexes instead of the base's own (a four-bar at 12 or 24 phases,
    #: whose base admits 6 alone)
    counts: tuple = ()


def problem_data(draw: Draw) -> dict:
    """The problem file (a dict) of ``draw``, its bounds not yet set (see :func:`build`)."""
    base = yaml.safe_load((ROOT / "problems" / f"{BASES[draw.mechanism]}.yaml").read_text())
    data = copy.deepcopy(base)
    data["name"] = f"oracle_{draw.mechanism}_{draw.seed}"
    data.pop("solver", None)
    problem = problem_from_dict(base, where="base.yaml")
    model = problem.model
    counts = draw.counts or problem.counts()
    data["design"][model.count_variable] = counts[draw.count % len(counts)]
    data["stroke"] = model.strokes[draw.stroke % len(model.strokes)]
    for k in problem.free_lengths():
        v = problem.design[k]
        centre = math.sqrt(v.lower * v.upper)
        span = 10 ** draw.decades
        lower = centre / span ** (1 - draw.centre)
        upper = lower * span
        lower, upper = _valid(draw.mechanism, k, lower, upper, problem)
        entry = {"lower": float(lower), "upper": float(upper)}
        if draw.initial and v.initial is not None and lower <= v.initial <= upper:
            entry["initial"] = float(v.initial)
        data["design"][k] = entry
    data["constraints"] = {k: v for k, v in (data.get("constraints") or {}).items()
                           if k != "min_pin_radius"} | \
        ({"min_pin_radius": 0.2 * base["constraints"]["min_pin_radius"]}
         if "min_pin_radius" in (base.get("constraints") or {}) else {})
    obj = dict(data.get("objective") or {})
    obj.pop("min_ratio", None)
    obj.pop("max_ripple", None)
    quantity, maximise = draw.objective
    obj["minimize"] = ("-" if maximise else "") + quantity
    if obj["minimize"] == "-ratio":
        obj["max_ripple"] = 10.0          # the largest ratio needs a cap (set in build)
    data["objective"] = obj
    return data


def _valid(mechanism: str, name: str, lower: float, upper: float, problem):
    """A widened range kept where the mechanism can assemble at all (the pulse reducer's
    crank below its pivot distance, the slotted lever's pivot beyond its circle)."""
    if mechanism == "pulse_reducer" and name == "r1":
        upper = min(upper, 0.999 * problem.design["a"].value)
        lower = min(lower, 0.5 * upper)
    if mechanism == "slotted_lever" and name == "XD":
        lower = max(lower, 1.001 * problem.design["L"].value)
        upper = max(upper, 2 * lower)
    return lower, upper


def build(draw: Draw):
    """The problem of ``draw`` (a loaded Problem), its bounds at quantiles of each bounded
    quantity over a sample of the box (a quantile beyond 0..1 puts the bound out of reach)."""
    return loaded(build_data(draw))


def loaded(data: dict):
    """The Problem of a draw's problem data (:func:`build_data`)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return problem_from_dict(copy.deepcopy(data), where=f"{data['name']}.yaml")


def build_data(draw: Draw) -> dict:
    """The problem file's data of ``draw`` (:func:`build`): its bounds read off the screening's
    sampled values of the box, so the code that screens decides their last bits (a comparison
    of two commits draws the problems once, with one of them: ``solve_answers_ab.py``)."""
    data = problem_data(draw)
    with warnings.catch_warnings():     # a widened box under 1 mm warns "metres?"
        warnings.simplefilter("ignore")
        plain = problem_from_dict(copy.deepcopy(data), where=f"{data['name']}.yaml")
    names = QUANTITIES[draw.mechanism]
    values = _sampled_values(plain, [names[i % len(names)] for i, _, _ in draw.bounds])
    constraints = data["constraints"]
    for i, side, quantile in draw.bounds:
        name = names[i % len(names)]
        finite = values.get(name, np.array([]))
        finite = finite[np.isfinite(finite)]
        if not finite.size:
            continue
        at = lambda q: float(np.quantile(finite, min(max(q, 0.0), 1.0)) *  # noqa: E731
                             (1.0 + 0.2 * max(q - 1.0, 0.0) - 0.2 * max(-q, 0.0)))
        if side == "both":
            low, high = sorted((at(quantile), at(min(quantile + 0.3, 1.0))))
            bound = {"lower": low, "upper": max(high, low * (1 + 1e-3) + 1e-9)}
        else:
            bound = {side: at(quantile)}
        constraints[name] = bound
        if name == "transmission_angle" and "lower" in bound:   # the same bound's older key
            constraints.pop("min_transmission_angle_deg", None)
    if data["objective"]["minimize"] == "-ratio":
        ripple = values.get("ripple")
        cap = float(np.nanquantile(ripple[np.isfinite(ripple)], 0.5)) \
            if ripple is not None and np.isfinite(ripple).any() else 0.5
        data["objective"]["max_ripple"] = max(cap, 1e-3)
        constraints.pop("ripple", None)
    return data


def _sampled_values(problem, names) -> dict:
    """Each named quantity's sampled value over 1024 designs of the box that assemble."""
    from optdesign.quantities.bounds import QuantityBound

    if not names:
        return {}
    specs = tuple(QuantityBound(n) for n in dict.fromkeys(names + ["ripple"]))
    loose = problem.with_quantity_bounds(specs)
    X, count = _box_sample(loose, 1024, 7)
    sampled: dict = {}
    sampled_scores(loose, count, _base(loose, count), loose.free_lengths(), X, sampled)
    return {s.name: np.asarray(sampled["quantities"][s.key], float) for s in specs}


def _base(problem, count: int) -> dict:
    return problem.start_values() | {problem.model.count_variable: count}


def _box_sample(problem, n: int, seed: int):
    free = problem.free_lengths()
    lower = np.array([problem.design[k].lower for k in free])
    upper = np.array([problem.design[k].upper for k in free])
    unit = np.random.default_rng(seed).random((n, len(free)))
    return spread(unit, lower, upper), problem.counts()[0]


@dataclass
class Sample:
    """The exactly checked designs of a box sample: the feasible ones' keys and designs."""

    checked: int = 0
    feasible: list = field(default_factory=list)       # (key, design)

    @property
    def best(self):
        return min(self.feasible, key=lambda f: f[0], default=None)


def sample(problem, seed: int = 11) -> Sample:
    """:data:`SAMPLE` designs of the box per count, the best :data:`CHECKED` by the sampled
    evaluator's rank and :data:`RANDOM` others (and the file's own design) checked exactly."""
    out = Sample()
    objective = objective_of(problem)
    free = problem.free_lengths()
    rng = np.random.default_rng(seed)
    for count in problem.counts():
        X, _ = _box_sample(problem, SAMPLE, seed + count)
        base = _base(problem, count)
        score, violation = sampled_scores(problem, count, base, free, X)
        ok = violation <= 0
        order = np.lexsort((np.where(ok, score, violation), ~ok))
        order = order[np.isfinite(violation[order])]
        picks = list(order[:CHECKED])
        rest = order[CHECKED:]
        if rest.size:
            picks += list(rng.choice(rest, size=min(RANDOM, rest.size), replace=False))
        designs = [base | dict(zip(free, X[i])) for i in picks] + [base]
        for design in designs:
            ver = verify(problem, design)
            out.checked += 1
            if ver.feasible:
                out.feasible.append((float(objective.key(ver.measured)), design))
    return out


def judge(problem, result, found: Sample) -> list[str]:
    """The false claims of ``result`` (a SolveResult) against the checked sample."""
    claims = []
    if result.status == "optimal":
        ver = verify(problem, result.design)
        if not ver.feasible:
            claims.append(f"optimal, but its design breaks {', '.join(ver.violations)}")
            return claims
        key = float(objective_of(problem).key(ver.measured))
        best = found.best
        if best is not None and best[0] < key - KEY_TOL * max(1.0, abs(key)):
            claims.append(f"optimal at {key:.6g}, but a sampled design reaches {best[0]:.6g}")
    elif found.feasible:
        claims.append(f"{result.status}, but {len(found.feasible)} sampled designs meet every "
                      f"constraint (best {found.best[0]:.6g})")
    return claims


def run(draw: Draw) -> dict:
    """Solve the problem of ``draw``, sample its box and judge: one row of the table."""
    problem = build(draw)
    t0 = time.perf_counter()
    result = solve(problem)
    seconds = time.perf_counter() - t0
    found = sample(problem)
    claims = judge(problem, result, found)
    spans = [problem.design[k].upper / problem.design[k].lower for k in problem.free_lengths()]
    return {"mechanism": draw.mechanism, "seed": draw.seed, "counts": list(problem.counts()),
            "decades": round(max(math.log10(s) for s in spans), 2) if spans else 0.0,
            "initial": draw.initial, "objective": problem.objective.minimize,
            "bounds": ", ".join(f"{s.key}{'≥' if math.isfinite(s.lower) else ''}"
                                f"{'≤' if math.isfinite(s.upper) else ''}"
                                for s in problem.quantity_bounds),
            "status": result.status, "solve_s": seconds, "checked": found.checked,
            "sampled_feasible": len(found.feasible), "false": len(claims),
            "claims": "; ".join(claims)}


def random_draw(rng: np.random.Generator, seed: int, counts: tuple = ()) -> Draw:
    """A draw from numpy's generator (the benchmark's; the test draws through hypothesis).
    With ``counts``, a four-bar at one of those phase counts."""
    mechanism = list(BASES)[int(rng.integers(len(BASES)))]
    if counts:
        mechanism = "fourbar_converter"
    names = QUANTITIES[mechanism]
    bounds = tuple((int(rng.integers(len(names))), str(rng.choice(["lower", "upper", "both"])),
                    float(rng.uniform(-0.1, 1.1)))
                   for _ in range(int(rng.integers(0, 3))))
    objective = (str(rng.choice(["ripple"] * 3 + list(names))), bool(rng.random() < 0.3))
    return Draw(mechanism, float(rng.uniform(1, 6)), float(rng.random()),
                bool(rng.random() < 0.5), int(rng.integers(4)), int(rng.integers(3)), bounds,
                objective, seed, tuple(counts))

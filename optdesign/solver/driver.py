"""Screen, polish the best basins with IPOPT, verify exactly: every admissible phase count.

Per phase count: the box is screened (:mod:`optdesign.solver.screening`), its best basins are
polished (:mod:`optdesign.solver.polishing`), each by IPOPT on the count's NLP, built once and
reused by every start, refinement and Pareto point, until the exact check agrees with it
(:mod:`optdesign.solver.phase_solver`); the screened designs and the file's own are the
answer's floor, and a count no polish meets is ``infeasible`` only where a verified search
shows its bound out of reach (:mod:`optdesign.solver.reachable`). The best verified design of
every count wins.
"""
from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from optdesign.errors import AssemblyError, ProblemError
from optdesign.evaluation.regulation import quantities_over_range
from optdesign.evaluation.sensitivity import made_before, made_key, sensitivity_record
from optdesign.numerics import lanes
from optdesign.quantities import design_quantities, unit_text
from optdesign.quantities.bounds import side_key
from optdesign.quantities.criteria import (LeastRipple, LengthConstraint, constraints_of,
                                           objective_of, quantity_specs, searched_quantities)
from optdesign.solver import count_order
from optdesign.solver.accuracy import solve_accuracy
from optdesign.solver.nlp import is_robust
from optdesign.solver.phase_solver import AS_IT_IS, Outcome, PhaseSolver, Timings
from optdesign.solver.polishing import Polishing, answer_record_beside
from optdesign.solver.reachable import reach_of
from optdesign.solver.refine import refine
from optdesign.solver.result import PhaseResult, SolveResult
from optdesign.solver.screening import FLOOR_MARGIN, Scored, ripple_floor, screen
from optdesign.solver.verify import verify

#: screened designs checked exactly when no polish converges (best ranked first)
CHECKED_WHEN_STUCK = 16

def workers_for(problem) -> int:
    """The cores a solve uses (the screening's threads, the best basins polished at once, the
    tolerance analysis's processes): ``solver.workers``, or (0) every core, where the
    platform can fork."""
    import multiprocessing as mp

    from optdesign.limits import local_processes

    if "fork" not in mp.get_all_start_methods():
        return 1
    return local_processes(problem.solver.workers)


def solve_phase(problem, count: int, solver: PhaseSolver | None = None,
                workers: int | None = None, neighbours: list[dict] = (),
                explain: bool = True, sensitivities: bool = False,
                scored: Scored | None = None) -> PhaseResult:
    """Best verified optimum of one phase count: screen (on ``workers`` threads; default
    :func:`workers_for`; 1 with a given ``solver``, whose built NLPs are kept for re-use),
    then polish the best basins (:meth:`Polishing.basins`). ``neighbours``: optima of other
    phase counts, screened with the box (continuation: the optimum of a neighbouring count
    often lies in the best basin of this one, and ranks first when it does).
    ``sensitivities``: the optimum's block computed here, on the evaluation its polish
    verified (a solve of one count; otherwise :func:`summarized` computes the answer's
    alone). ``scored``: the count's box sample scored already
    (:func:`~optdesign.solver.screening.promise`), used where the screening has no neighbour
    to add.

    The verdict is a claim with its evidence. The design the file gives (its fixed and
    initial values) is a candidate as it is, so the answer is never worse than it. With
    ``explain``, a count no polish meets is ``infeasible`` only where a verified relaxed solve
    shows the binding bound out of reach (:mod:`optdesign.solver.reachable`); where the
    relaxed optimum meets the bound, the polish goes on from it. When no screened design
    passes the filters, that relaxed solve comes first: an out-of-reach bound is told at the
    cost of one solve, not of every start failing first."""
    if not problem.free_lengths():
        fixed = _fixed_infeasible(problem, count)
        if fixed is not None:
            return fixed
    out_of_reach = _bounds_crossed(problem, count) or _beyond_the_box(problem, count)
    if out_of_reach is not None:
        return out_of_reach
    if workers is None:
        workers = 1 if solver is not None else workers_for(problem)
    solver = solver or PhaseSolver(problem, count)
    robust = is_robust(problem)
    # a robust solve screens and polishes the nominal problem first (_from_nominal_optima)
    basins = solver.nominal_solver() if robust else solver
    with basins.timings.stage("screening"), lanes.threads(workers):
        screening = screen(basins.problem, count, problem.solver.screen,
                           extra=list(neighbours), scored=None if robust else scored)
    result = PhaseResult(count, "failed", screening=screening.to_dict())
    work = Polishing(basins.problem, count, basins, result, workers)
    given = problem.start_values() | {problem.model.count_variable: count}
    if not robust and _user_gave(problem):
        work.checked_later.append(given)        # as it is, below: checked while a polish waits
    work.records_later = not robust             # (a robust answer is the robust polishes')
    relax = explain and not robust and bool(screening.seeds)
    reach = None
    if relax and screening.n_feasible == 0:
        # the bound most of the sample misses first
        missed = sorted(screening.missed, key=lambda n: -screening.missed[n])
        reach = _reach(problem, count, missed[0] if missed else None, workers, [given],
                       result, basins.timings)
        if reach is not None and reach.out_of_reach:
            result.timings = solver.timings.to_dict()
            return _infeasible(result, problem, count, reach)
    seeds = list(screening.seeds)
    if reach is not None and reach.design is not None:
        seeds.insert(0, _seed(problem, reach.design))   # meets every bound: polish it first
    work.basins(seeds, screening.leads)
    work.rescue()
    work.lines()
    if work.best is None and relax and reach is None:
        reach = _reach(problem, count, _binding_of(result), workers,
                       [given] + [o.values for o in work.outcomes], result, basins.timings)
        if reach is not None and reach.out_of_reach:
            result.timings = solver.timings.to_dict()
            return _infeasible(result, problem, count, reach)
        if reach is not None and reach.design is not None:
            work.polish(reach.design)
            work.consider(basins.as_it_is(reach.design))
    if not robust and _user_gave(problem):
        if work.best is None:           # no polish got there: polish from the user's design
            work.polish(given)
        # checked already beside a polish (its check in memory), or checked now unless the
        # optimum beats it for certain
        if given not in work.checked_later or not _beaten(problem, count, given, work.best):
            work.consider(basins.as_it_is(given))
    if not robust:
        _screened_floor(work, screening, basins)
    result.screening |= {"polished": work.polished, "distinct_optima": len(work.optima)}
    if robust:
        solver.checks_in_parallel = workers > 1
        work = _from_nominal_optima(problem, count, solver, work, screening.seeds)
    result.timings = solver.timings.to_dict()
    if work.best is not None:
        return _fill(result, problem, work.best, sensitivities,
                     quantities_made=work.quantities_made is work.best)
    if not screening.seeds:
        result.status, result.binding = "infeasible", "assembly"
        result.message = (f"no design within the bounds assembles at every listed "
                          f"eccentricity with {count} phases")
        return result
    result = _no_optimum(result, problem)
    if reach is not None:
        result.reachable = reach.to_dict()
    return result


def _screened_floor(work: "Polishing", screening, solver: PhaseSolver) -> None:
    """The screened designs as the answer's floor: a design the solve has seen is never
    better than what it returns. Where no polish converged, the best screened designs are
    checked exactly; otherwise those whose sampled objective beats the best optimum (a
    polish that ended in a poorer local optimum, or short of a dead point). A screened design
    that wins is polished once more from where it lies; where the best is still a known design
    and not a converged polish, or a polish that ended where the output comes to rest once a
    turn (an edge of the NLP, not of the problem), it is refined on the exact check
    (:mod:`.refine`)."""
    converged = work.converged()
    feasible = [c for c in screening.candidates if c.feasible]
    if not converged:
        ranked = sorted(feasible, key=lambda c: c.score)
    else:
        best = work.best.verification.key
        ranked = sorted((c for c in feasible if c.objective < best), key=lambda c: c.objective)
    before = work.best
    for candidate in ranked[:CHECKED_WHEN_STUCK]:
        work.consider(solver.as_it_is(candidate.values))
    if work.best is not before:
        work.polish(work.best.values)
    if work.best is not None and (work.best.record.ipopt_status == AS_IT_IS or
                                  work.best.at_rest):
        # still a known design, not a converged polish, or a polish stopped where the output
        # comes to rest (the NLP's edge): refined on the exact check alone
        with solver.timings.stage("verification"):
            better = refine(work.problem, work.best.values, work.best.verification.key)
        if better is not None:
            work.consider(solver.as_it_is(better, note="refined on the exact check from "
                                                       "the best known design"))


def _beaten(problem, count: int, values: dict, best: Outcome | None) -> bool:
    """Whether ``best``, verified, beats the design ``values`` whatever its exact check would
    say: the objective is the least worst δ and the design's sampled floor of δ
    (:func:`~optdesign.solver.screening.ripple_floor`) lies above the optimum's δ. Its check
    is then not made (it could not win: :meth:`Polishing.consider` would pass it over)."""
    if best is None or not isinstance(objective_of(problem), LeastRipple):
        return False
    floor = ripple_floor(problem, count, values)
    return floor > best.verification.key * (1 + FLOOR_MARGIN)


def _user_gave(problem) -> bool:
    """Whether the file gives a design of its own: every length fixed, or an initial value of
    a free one (without any, the start is only the middle of the box)."""
    free = [problem.design[k] for k in problem.free_lengths()]
    return not free or any(v.initial is not None for v in free)


def _reach(problem, count: int, binding, workers: int, known, result: PhaseResult,
           timings: Timings):
    """:func:`~optdesign.solver.reachable.reach_of` the count. Its relaxed solves are this
    count's work: their IPOPT iterations are counted in ``result`` and their stages' seconds
    added to ``timings`` stage by stage; the rest of the search's wall time (the exact checks
    of the designs it weighs) is verification."""
    solved: list[PhaseResult] = []

    def counted(*args, **kwargs) -> PhaseResult:
        solved.append(solve_phase(*args, **kwargs))
        return solved[-1]

    t0 = time.perf_counter()
    try:
        return reach_of(problem, count, binding, counted, workers, known)
    finally:
        spent = Timings()
        for relaxed in solved:
            spent.add(Timings(**relaxed.timings) if relaxed.timings else Timings())
            result.iterations += relaxed.iterations
        rest = time.perf_counter() - t0 - (spent.total() - spent.beside)
        spent.verification += max(rest, 0.0)
        timings.add(spent)


def _binding_of(result: PhaseResult) -> str | None:
    """The constraint the failed polishes most often ended on (IPOPT's word first)."""
    verdicts = [r.note for r in result.starts
                if r.note and r.ipopt_status == "Infeasible_Problem_Detected"]
    notes = verdicts or [r.note for r in result.starts if r.note]
    return max(set(notes), key=notes.count) if notes else None


def _seed(problem, values: dict):
    """A design to polish first, as a screening's seed."""
    from optdesign.solver.screening import Candidate

    free = problem.free_lengths()
    return Candidate({k: float(values[k]) for k in values}, -np.inf, True,
                     np.zeros(len(free)))


def _infeasible(result: PhaseResult, problem, count: int, reach) -> PhaseResult:
    """The count is out of reach of ``reach``'s bound: its verified nearest value."""
    result.status, result.binding = "infeasible", reach.constraint
    result.reachable = reach.to_dict()
    result.message = reach.text(problem.model.count_variable, count)
    return result


def _from_nominal_optima(problem, count: int, solver: PhaseSolver, nominal: "Polishing",
                         seeds) -> "Polishing":
    """The robust polishes of one count, from the optima of its nominal problem (``nominal``,
    screened and polished as any solve), best first, each held at its box's worst corners
    from the start (:meth:`PhaseSolver.solve_from`). An optimum whose nominal δ is not below
    the best worst δ found is not polished: a design's worst δ over its box is at least its
    own δ, which in that basin is at least the basin's nominal optimum. Where no nominal
    optimum leads to a robust one, the nominal problem's seeds are polished robustly (the
    box may need a basin the nominal problem leaves); without a nominal optimum there is no
    robust one (every part's constraints hold the nominal's too). ``result.starts`` holds the
    nominal polishes (``screening.polished`` of them) and then the robust ones
    (``screening.robust_polished``); the iterations and stage times count both."""
    result = nominal.result
    solver.timings.add(nominal.solver.timings)
    work = Polishing(problem, count, solver, result)
    for optimum in sorted(nominal.optima, key=lambda o: o.verification.key):
        if work.best is not None and \
                optimum.verification.key >= work.best.verification.key:
            break
        work.polish(optimum.values)
    if work.best is None and nominal.optima:
        work.basins(seeds)
    result.screening |= {"robust_polished": work.polished}
    return work


def _no_optimum(result: PhaseResult, problem) -> PhaseResult:
    """No polish reached a verified feasible design and no relaxed solve showed a bound out
    of reach: ``failed``, naming where the polishes ended in the file's words."""
    result.status = "failed"
    statuses = sorted({r.ipopt_status for r in result.starts})
    result.binding = _binding_of(result)
    where = _in_user_words(problem, result.binding)
    result.message = (f"no polish reached a design that meets every constraint (IPOPT: "
                      f"{', '.join(statuses) or 'not run'})"
                      + (f"; the polishes ended short of {where}" if where else ""))
    return result


def _in_user_words(problem, row: str | None) -> str:
    """The problem file's key behind an NLP row or a criterion name (``min_ratio[e1]`` ->
    ``objective.min_ratio``); the output-speed envelope's own rows in words."""
    if not row:
        return ""
    name = row.split("[", 1)[0]
    for criterion in constraints_of(problem):
        if name in (criterion.name, criterion.name.split("[", 1)[0]):
            return criterion.key(problem)
    for spec in quantity_specs(problem):
        if name.endswith(f"_{spec.name}") or name.endswith(f"_{spec.key}"):
            return next((c.key(problem) for c in constraints_of(problem)
                         if c.name == spec.key), f"the {spec.name} objective")
    return "the output-speed envelope's tracked extremes (a linkage near a dead point)"


def _bounds_crossed(problem, count: int) -> PhaseResult | None:
    """A quantity whose lower bound lies above its upper one (two keys of the file that bound
    one figure, e.g. ``min_transmission_angle_deg: 40`` and ``transmission_angle: {upper:
    0}``): no design meets both, so the count is ``infeasible`` before any solve."""
    for spec in problem.constraints.bounds:
        if spec.lower > spec.upper:
            unit = unit_text(spec.name)
            keys = [side_key(problem.constraints.spelled, spec, side)
                    for side in ("lower", "upper")]
            return PhaseResult(
                count, "infeasible", binding=spec.key,
                message=f"{spec.key} must be at least {spec.lower:g}{unit} ({keys[0]}) and "
                        f"at most {spec.upper:g}{unit} ({keys[1]}): no design meets both")
    return None


def _beyond_the_box(problem, count: int) -> PhaseResult | None:
    """A length constraint no design in the bounds can meet, decided from the bounds alone:
    a formula linear in the lengths (the four-bar's pin radius, l2 − l2′) takes its extremes
    over the box at its corners, so a bound beyond them is ``infeasible`` with the reachable
    value, before any solve."""
    import itertools

    import casadi as ca

    names = list(problem.model.lengths)
    sym = ca.SX.sym("l", len(names))
    box = [(problem.design[k].lower, problem.design[k].upper) if problem.design[k].is_free
           else (problem.design[k].value,) * 2 for k in names]
    for c in constraints_of(problem):
        if not isinstance(c, LengthConstraint):
            continue
        expr = c.formula({k: sym[i] for i, k in enumerate(names)})
        if ca.depends_on(ca.jacobian(expr, sym), sym):
            continue                            # not linear: its extremes need not be corners
        f = ca.Function("f", [sym], [expr])
        values = [float(f(corner)) for corner in itertools.product(*box)]
        lower, upper = c.bounds(problem)
        most, least = max(values), min(values)
        if most < lower or least > upper:
            side, reach = ("least", lower) if most < lower else ("most", upper)
            value = most if most < lower else least
            unit = "" if c.unit in ("", "-") else f" {c.unit}"
            return PhaseResult(
                count, "infeasible", binding=c.name,
                message=f"{c.name} must be at {side} {reach:g}{unit}, and no design in the "
                        f"bounds reaches it: the {'largest' if most < lower else 'least'} "
                        f"{c.name} the bounds allow is {value:g}{unit}")
    return None


def _fixed_infeasible(problem, count: int) -> PhaseResult | None:
    """Every length fixed and the exact check fails: nothing for IPOPT to move, so say which
    constraint the design violates (instead of IPOPT failing on the NLP's inner variables)."""
    values = problem.start_values() | {problem.model.count_variable: count}
    ver = verify(problem, values)
    if ver.feasible:
        return None
    names = ", ".join(ver.violations)
    return PhaseResult(count, "infeasible", binding=next(iter(ver.violations), None),
                       message=f"the fixed design violates {names}"
                               + (f" ({ver.message})" if ver.message else ""))


def _fill(result: PhaseResult, problem, outcome: Outcome, sensitivities: bool = False,
          quantities_made: bool = False) -> PhaseResult:
    ver, values = outcome.verification, outcome.values
    design = {k: float(values[k]) for k in problem.model.lengths}
    design[problem.model.count_variable] = result.count
    result.status = "optimal"
    result.design = design
    result.delta = ver.delta
    result.ratio = ver.ratio
    result.min_transmission_angle_deg = ver.min_angle_deg
    result.surrogate_delta = outcome.surrogate
    # the NLP's t bounds the worst held part: compared with the box's worst in a robust solve
    reference = ver.worst_cases[0].value if ver.worst_cases else ver.delta
    result.surrogate_gap = None if outcome.surrogate is None else outcome.surrogate - reference
    result.regulation = ver.regulation()
    result.worst_eccentricity = ver.worst_eccentricity
    if ver.worst_cases:
        ripple, angle, *bounded = ver.worst_cases
        result.worst_case_delta = ripple.value
        result.worst_case_min_transmission_angle_deg = angle.value
        result.worst_case_quantities = {case.quantity: case.value for case in bounded}
    result.active = outcome.record.active
    # the sensitivities on the evaluation at hand, where this process has the quantities
    # still to find (no wait for a polish beside made them ahead), by the child the polishes
    # beside ran in, where it is idle, while this process finds them (the same values): any
    # such child where this process has not made a record at the count (the chains'
    # gradient functions, most of a first record, to build here as there), else one that
    # has made one too (with the quantities made, the record is made here: a child would
    # add the trip there and back to a record this process makes as fast)
    here = made_before(problem, result.count)
    pending = answer_record_beside(problem, result.count, sensitivity_record, problem, design,
                                   ver.evaluation, builds=made_key(problem, result.count),
                                   built_there=here) \
        if sensitivities and not quantities_made else None
    try:
        result.quantities = design_quantities(
            problem, _every_quantity_searched(problem, ver.evaluation))
        if pending is not None:
            try:
                result.sensitivities = pending()
            except Exception:       # noqa: BLE001 - not made there: made here (its error too)
                pending = None
        if sensitivities and pending is None:
            result.sensitivities = sensitivity_record(problem, design, ver.evaluation)
    except BaseException:
        if pending is not None:
            pending.cancel()
        raise
    result.message = ""
    return result


def _every_quantity_searched(problem, ev):
    """``ev`` with the worst over the regulation interval of every quantity the report gives
    (the verification searched only those the criteria read); ``ev`` itself without an
    interval, or when a further search point does not assemble."""
    if ev.worst is None:
        return ev
    missing = [n for n in searched_quantities(ev.design) if n not in ev.worst.quantities]
    try:
        found = quantities_over_range(ev.design, problem.stroke, problem.input_speed,
                                      problem.objective.ripple, *problem.eccentricity_range,
                                      names=missing)
    except (AssemblyError, ProblemError):
        return ev
    return replace(ev, worst=replace(ev.worst, quantities=ev.worst.quantities | found))


def solve(problem, progress=None) -> SolveResult:
    """Solve the problem for every admissible phase count and pick the best verified one:
    the counts in the order of their promise, a count that cannot beat the best optimum found
    not polished (:mod:`optdesign.solver.count_order`)."""
    t0 = time.perf_counter()
    per_phase: list[PhaseResult] = []
    counts = problem.counts()
    objective = objective_of(problem)
    # the solve owns its cores: a call of the compiled lanes (an exact check's grid) shares its
    # lanes between them (optdesign.numerics.lanes.threads; the same values to the bit)
    with lanes.threads(workers_for(problem)):
        for n, scored in count_order.ranked(problem):
            best = min((p for p in per_phase if p.status == "optimal"),
                       key=objective.result_key, default=None)
            if count_order.outranked(problem, scored, best):
                per_phase.append(count_order.outranked_result(problem, scored, best))
            else:
                polished = [p for p in per_phase if p.status != count_order.OUTRANKED]
                neighbours = [p.design for p in polished[-1:] if p.status == "optimal"]
                # one count is the answer if any is: its sensitivities on its own evaluation
                result = solve_phase(problem, n, neighbours=neighbours,
                                     sensitivities=len(counts) == 1, scored=scored)
                if scored is not None:      # (a count decided before any solve has none)
                    result.timings["screening"] = (result.timings.get("screening", 0.0) +
                                                   scored.seconds)
                per_phase.append(result)
            if progress:
                progress()
        return summarized(problem, sorted(per_phase, key=lambda p: p.count), t0)


def summarized(problem, per_phase: list[PhaseResult], t0: float) -> SolveResult:
    """The SolveResult of the counts solved (``per_phase``, in order) since ``t0``
    (``time.perf_counter()``): the best optimal count by the objective, else infeasible
    when every count is, else failed."""
    ok = [p for p in per_phase if p.status == "optimal"]
    objective = objective_of(problem)
    if is_robust(problem):      # a robust solve ranks by the tolerance box's worst δ
        best = min(ok, key=lambda p: p.worst_case_delta, default=None)
    else:
        best = min(ok, key=objective.result_key, default=None)
    if best:
        status, message = "optimal", ""
    else:
        status = "infeasible" if all(p.status == "infeasible" for p in per_phase) else "failed"
        message = "; ".join(f"n={p.count}: {p.message}" for p in per_phase)
    timings = Timings()
    for p in per_phase:
        timings.add(Timings(**p.timings) if p.timings else Timings())
    with timings.stage("verification"):
        accuracy = solve_accuracy(problem, best)        # inside solve_time_s: part of the solve
        if best is not None and not best.sensitivities:     # the answer's alone
            best.sensitivities = sensitivity_record(problem, best.design)
    return SolveResult(
        name=problem.name, status=status,
        design=best.design if best else None,
        delta=best.delta if best else None,
        ratio=best.ratio if best else None,
        min_transmission_angle_deg=best.min_transmission_angle_deg if best else None,
        worst_eccentricity=best.worst_eccentricity if best else None,
        worst_case_delta=best.worst_case_delta if best else None,
        quantities=best.quantities if best else {},
        solve_time_s=time.perf_counter() - t0,
        iterations=sum(p.iterations for p in per_phase),
        per_phase=per_phase,
        objective={"minimize": problem.objective.minimize, "ripple": problem.objective.ripple,
                   "min_ratio": problem.constraints.min_ratio,
                   "max_ripple": problem.constraints.max_ripple,
                   "eccentricities": list(problem.eccentricities),
                   **({"eccentricity_range": list(problem.eccentricity_range)}
                      if problem.eccentricity_range is not None else {})},
        accuracy=accuracy, active=best.active if best else [],
        message=message, stroke=problem.stroke, mechanism=problem.mechanism,
        input_speed=problem.input_speed, timings_s=timings.to_dict())

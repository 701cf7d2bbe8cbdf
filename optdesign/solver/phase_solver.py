"""One phase count's NLP polished from one start, until the exact check agrees with it.

A :class:`PhaseSolver` holds the NLPs of one phase count (:class:`~optdesign.solver.nlp.PhaseNLP`,
built once and kept for the process, :mod:`optdesign.solver.built`) and runs IPOPT from any
start (:meth:`PhaseSolver.solve_from`); each run's end is re-verified exactly
(:mod:`optdesign.solver.verify`) and re-solved while its exact structure disagrees with the
NLP's (hand-over order, an angle on its window, the transmission angle dipping between
samples), while the worst eccentricity inside a regulation interval is not held (it is then
held in an eccentricity slot, :func:`next_held`), and in a robust solve while the tolerance
box's worst parts are not held (scenario slots, :mod:`optdesign.solver.robust`). Which starts
are polished is :mod:`optdesign.solver.polishing`'s; the solve of every count is
:mod:`optdesign.solver.driver`'s.
"""
from __future__ import annotations

import hashlib
import time
from contextlib import contextmanager
from dataclasses import asdict, dataclass, replace

import numpy as np

from optdesign.envelope.sampled import STROKE_SIGNS
from optdesign.lifetime import interrupts_kept
from optdesign.quantities import get_quantity
from optdesign.quantities.criteria import (bound_excess, constraints_of, interval_quantities,
                                           objective_of, quantity_specs, quantity_tolerance)
from optdesign.solver import built
from optdesign.solver.nlp import Held, PhaseNLP, SECONDARY_BUDGET, is_robust
from optdesign.solver.result import StartRecord
from optdesign.solver.robust import (next_scenarios, robust_verdict, screened_cases,
                                     worst_cases)
from optdesign.solver.screening import of_decades
from optdesign.solver.verify import TOL_ANGLE_DEG, Verification, start_guess, verify

SUCCESS = ("Solve_Succeeded", "Solved_To_Acceptable_Level")
ACCEPTABLE = SUCCESS[1]
#: the status of a run stopped because it entered a known optimum's neighbourhood
JOINED = "Joined_Known_Basin"
#: the status of a run stopped while still far from feasible (nlp.STALL_AFTER iterations)
STALLED = "Stalled_Infeasible"
#: the status of a secondary basin's polish stopped at its budget (nlp.SECONDARY_BUDGET)
EXHAUSTED = "Secondary_Budget_Exhausted"
MAX_REFINEMENTS = 4
#: re-solves with new held eccentricities (a regulation interval), besides MAX_REFINEMENTS
MAX_REGULATION_STEPS = 6
#: the worst δ inside the interval may exceed the held eccentricities' worst by this much
REGULATION_TOL = 1e-8
#: a new worst eccentricity this close (share of the interval) to a held one moves that slot
SAME_SLOT = 0.05
#: re-solves with new scenario parts (a robust solve), besides MAX_REFINEMENTS
MAX_ROBUST_STEPS = 6
ANGLE_SAFETY_DEG = 0.01
#: a warm-started run not converged in this many iterations (it jumped across a change of the
#: active set, where the exact Hessian's iterations cost more than a cold run's) is stopped
#: and run again cold
WARM_BUDGET = 12

@dataclass
class Timings:
    """Wall time per stage, seconds."""

    build: float = 0.0
    screening: float = 0.0
    ipopt: float = 0.0
    verification: float = 0.0
    #: of the stages' time above, the seconds spent in a process beside the solve's own, at
    #: the same time as it (the best basins polished at once:
    #: :meth:`optdesign.solver.polishing.Polishing.basins`)
    beside: float = 0.0

    @contextmanager
    def stage(self, name: str):
        t0 = time.perf_counter()
        try:
            yield
        finally:
            setattr(self, name, getattr(self, name) + time.perf_counter() - t0)

    def add(self, other: "Timings") -> None:
        for k, v in other.to_dict().items():
            setattr(self, k, getattr(self, k) + v)

    def total(self) -> float:
        """The stages' seconds, summed (``beside`` is a part of them, not a stage)."""
        return sum(v for k, v in self.to_dict().items() if k != "beside")

    def to_dict(self) -> dict:
        return asdict(self)


#: the IPOPT status of a known design taken as it is (:meth:`PhaseSolver.as_it_is`)
AS_IT_IS = "Known_Design_As_It_Is"


@dataclass
class Outcome:
    """What one polish returns: the IPOPT record, the exact verification of the design it
    ended on, that design's values, and the surrogate's worst δ there."""

    record: StartRecord
    verification: Verification
    values: dict
    surrogate: float | None
    #: the polish ended where the output comes to rest once a turn (the NLP's edge, which
    #: the exact envelope crosses: :meth:`PhaseNLP.output_at_rest`)
    at_rest: bool = False
    #: the primal-dual solution of the IPOPT run that gave ``values`` and its NLP's
    #: signature (plain lists: a journal keeps it), for a neighbour's warm start; None where
    #: the design is not a run's optimum (a start kept as it is, a run not accepted)
    warm: dict | None = None


class PhaseSolver:
    """Solves the NLP of one phase count from any start, on NLPs built once and kept."""

    def __init__(self, problem, count: int):
        self.problem = problem
        self.count = count
        self.timings = Timings()
        #: the NLPs this solver has used, by slots (each kept for the process as well:
        #: :mod:`optdesign.solver.built`)
        self._nlps: dict[int, PhaseNLP] = {}
        #: optima found already: a run that reaches one of them is stopped (its basin is known)
        self.avoid: list[dict] = []
        self._nominal: PhaseSolver | None = None       # a robust problem's nominal solver
        #: a robust solve's tolerance analyses search δ and the rest in two processes
        self.checks_in_parallel = False

    def nlp(self, sequences) -> PhaseNLP:
        """The NLP with enough hand-over slots for ``sequences`` (built at most once)."""
        need = max((len(s) for s in sequences), default=1)
        for slots, nlp in self._nlps.items():
            if slots >= need:
                return nlp
        return self.nlp_of(max(need, self.curves()))   # a slot per curve, more if need be

    def held_slots(self) -> tuple[int, ...]:
        """The slots of the NLPs this solver holds, in the order it came to hold them (a
        polish takes the first with enough: :meth:`nlp`)."""
        return tuple(self._nlps)

    def curves(self) -> int:
        """The count's speed curves (a rocker's stroke each): the NLP's least slots."""
        return self.count * len(STROKE_SIGNS[self.problem.stroke])

    def nlp_of(self, slots: int) -> PhaseNLP:
        """The NLP of exactly ``slots`` hand-over slots, held by this solver from now on."""
        if slots not in self._nlps:
            self._nlps[slots] = self._kept(slots)
        return self._nlps[slots]

    def _kept(self, slots: int) -> PhaseNLP:
        """The process's NLP of this count with ``slots`` slots (:mod:`.built`; built at most
        once: exactly the one this solver would build, the same run)."""
        kept = built.kept(self.problem, self.count)
        nlp = kept.get(slots)
        if nlp is None:
            with self.timings.stage("build"):
                nlp = kept[slots] = PhaseNLP(self.problem, self.count, slots)
        return nlp

    def prepare(self) -> None:
        """Build now, for the process, the NLP a polish of this count most often asks for (a
        slot per curve) and its IPOPT of the problem's Hessian: a process forked after this
        inherits them. This solver does not hold it until a polish asks for it (which NLP a
        polish takes depends on those it holds: :meth:`nlp`)."""
        nlp = self._kept(self.curves())
        with self.timings.stage("build"):
            nlp.solver(self.problem.solver.hessian)

    def nominal_solver(self) -> "PhaseSolver":
        """The solver of this robust problem's nominal problem (the design alone, not its
        box), kept with its NLPs; its stage times start afresh on each call."""
        if self._nominal is None:
            plain = replace(self.problem.objective, robust="none")
            self._nominal = PhaseSolver(replace(self.problem, objective=plain), self.count)
        self._nominal.timings = Timings()
        return self._nominal

    def verify(self, problem, values, held: Held | None = None,
               search: bool = True) -> Verification:
        with self.timings.stage("verification"):
            return verify(problem, values, held, search)

    def solve_from(self, values: dict, min_ratio=None, max_ripple=None,
                   ver: Verification | None = None, secondary: bool = False,
                   bound=None, warm: dict | None = None) -> Outcome:
        """IPOPT from one start; refined until the exact check agrees with the NLP's structure.

        ``min_ratio``, ``max_ripple`` and ``bound`` (a QuantityBound, tightening the problem's
        own bound of that quantity) move bounds for this solve only, as a Pareto point's ε.
        A quasi-Newton run that stalls (or runs out of iterations) is retried once with the
        exact Hessian, unless the start is ``secondary`` (a further basin polished beside the
        best one: a stalled run there is abandoned, not rescued). ``warm``: the
        :attr:`Outcome.warm` of the polish that ended on ``values`` (a neighbour's optimum
        under its own bound): the first run starts from its primal-dual solution where the
        NLP is the same (:meth:`_ipopt`); a warm run that does not succeed is run again cold."""
        problem = self.at(min_ratio, max_ripple, bound)
        # a start is checked at the listed eccentricities only; the first polish's result is
        # searched over the whole regulation interval
        ver = ver or self.verify(problem, values, search=False)
        start, t0 = dict(values), time.perf_counter()
        robust = is_robust(problem)
        if robust and ver.sequences and not any(ver.held.scenario_active):
            # the nominal and the start's worst corners (screened on the lanes) to begin with
            cases, corners, spare = self.screened_cases(problem, values)
            seeded = next_scenarios(problem, ver.held, cases, None, corners, fill=spare)
            ver = self.verify(problem, values, seeded, search=False)
        held = ver.held
        # The NLP holds the worst transmission angle at exact points: no margin to start with;
        # a dip the exact check still finds tightens the bound by the deficit.
        iterations, status, surrogate, multiplier, note = 0, "not run", None, None, ""
        at_rest, primal_dual = False, None
        active: list = []
        tightening, hessian = 0.0, problem.solver.hessian
        refinements = regulation_steps = robust_steps = 0
        while refinements < MAX_REFINEMENTS:
            refinements += 1
            if not ver.sequences:
                note = ver.message
                break
            run = self._ipopt(problem, ver, tightening, hessian,
                              SECONDARY_BUDGET - iterations if secondary else None, warm)
            warm = None                 # the first run's alone
            if run.warm and run.status not in SUCCESS:
                iterations += run.iterations      # counted, and the run made again cold
                refinements -= 1
                continue
            status, surrogate, multiplier, active = (run.status, run.surrogate,
                                                     run.multiplier, run.active)
            at_rest = run.at_rest
            iterations += run.iterations
            trial = values | run.lengths
            primal_dual = None
            # Where the run ends decides what follows; the exact check of where it stopped is
            # made only where something reads it (a stopped or retried run keeps its start's)
            if hessian == "limited-memory" and not secondary and (
                    status == "Maximum_Iterations_Exceeded" or
                    status == "Infeasible_Problem_Detected" and of_decades(problem)):
                # The quasi-Newton run stalled: once more from the same start with CasADi's
                # exact Hessian, which converges, or certifies local infeasibility, where
                # L-BFGS wanders (in a box of decades, given three times the iterations, it
                # wanders far enough to call a feasible start's basin infeasible)
                hessian = "exact"
                continue
            if status == STALLED:
                note = f"still infeasible after {run.iterations} iterations"
                break
            if status == EXHAUSTED:
                note = f"a secondary basin not converged in {SECONDARY_BUDGET} iterations"
                break
            if status == JOINED:
                note = "joined the basin of an optimum found from another start"
                break
            new = self.verify(problem, trial, held)
            if status not in SUCCESS:
                note = run.binding
                values, ver = (trial, new) if new.sequences else (values, ver)
                break
            given, (values, ver) = ver.sequences, (trial, new)
            primal_dual = run.primal_dual
            if status == ACCEPTABLE and hessian == "limited-memory" and not secondary:
                # stopped at IPOPT's looser tolerance (a flat valley, an optimum at the box's
                # far edge): on from here with the exact Hessian, to the full tolerance
                hessian = "exact"
                continue
            moved = next_held(problem, ver)
            if moved != held:
                if regulation_steps < MAX_REGULATION_STEPS:
                    # the worst inside the regulation interval is not held: hold it (a
                    # parameter of the NLP) and re-solve from here
                    regulation_steps += 1
                    refinements -= 1
                    held = moved
                    ver = self.verify(problem, values, held)
                    continue
                note = (f"the worst eccentricity {ver.worst_eccentricity:g} of the interval "
                        f"still moved after {MAX_REGULATION_STEPS} re-solves")
            dips = [ver.violations[c.name] for c in constraints_of(problem)
                    if c.tightens and c.name in ver.violations]
            if dips:        # a dip between the NLP's tracked extremes: hold the bound tighter
                tightening += max(dips) + ANGLE_SAFETY_DEG
                continue
            if any(spec.key in ver.violations for spec in quantity_specs(problem)):
                continue        # another extreme than the tracked one became the largest
            if not _same_cycles(ver.sequences, given) or run.at_window or run.picks_moved:
                continue        # hand-overs changed order, an angle ran to its window, or
                #                 the attained figure moved to another curve or joint
            if robust:
                # the tolerance box's worst parts of this optimum: a part rougher than the
                # bound t, or one that breaks the angle, becomes a scenario; re-solve. The
                # corners screened on the lanes first; where they bring nothing new, the
                # tolerance analysis (which certifies the optimum)
                cases, corners, _ = self.screened_cases(problem, values)
                grown = next_scenarios(problem, held, cases, surrogate, corners,
                                       binding=run.binding_parts)
                if grown == held:
                    ver.worst_cases, ver.corners = self.worst_cases(problem, values)
                    grown = next_scenarios(problem, held, ver.worst_cases, surrogate,
                                           ver.corners, binding=run.binding_parts)
                if grown != held and robust_steps < MAX_ROBUST_STEPS:
                    robust_steps += 1
                    refinements -= 1
                    held = grown
                    ver = self.verify(problem, values, held)
                    continue
            break
        if robust:
            with self.timings.stage("verification"):
                robust_verdict(problem, values, ver)
        record = StartRecord(start=start, ipopt_status=status, iterations=iterations,
                             time_s=time.perf_counter() - t0,
                             feasible=bool(ver.feasible and status in SUCCESS),
                             delta=ver.delta, note=note, ratio_multiplier=multiplier,
                             active=_in_objective_units(problem, active, ver)
                             if status in SUCCESS else [])
        return Outcome(record, ver, values, surrogate, at_rest,
                       primal_dual if record.feasible else None)

    def at(self, min_ratio=None, max_ripple=None, bound=None):
        """The problem with a Pareto point's bounds (see :meth:`solve_from`)."""
        problem = self.problem
        if min_ratio is not None:
            problem = problem.with_limit("ratio", "lower", min_ratio or None)
        if max_ripple is not None:
            problem = problem.with_limit("ripple", "upper", max_ripple)
        if bound is not None:
            problem = tightened(problem, bound)
        return problem

    def as_it_is(self, values: dict, min_ratio=None, max_ripple=None, bound=None,
                 note: str = "the start itself, verified under the point's bounds") -> Outcome:
        """``values`` verified exactly under the point's bounds, without a polish: a known
        design that meets them is itself a candidate for the point (IPOPT from it may end in
        a worse local optimum)."""
        problem = self.at(min_ratio, max_ripple, bound)
        ver = self.verify(problem, values)
        record = StartRecord(start=dict(values), ipopt_status=AS_IT_IS, iterations=0,
                             time_s=0.0, feasible=bool(ver.feasible), delta=ver.delta,
                             note=note)
        return Outcome(record, ver, dict(values), None)

    def worst_cases(self, problem, values) -> tuple:
        """The tolerance analysis of ``values`` (:func:`optdesign.solver.robust.worst_cases`)."""
        with self.timings.stage("verification"):
            return worst_cases(problem, values, self.checks_in_parallel)

    def screened_cases(self, problem, values) -> tuple:
        """The box's corners screened (:func:`optdesign.solver.robust.screened_cases`)."""
        with self.timings.stage("verification"):
            return screened_cases(problem, values)

    def ipopt_arguments(self, problem, ver: Verification,
                        tightening: float = 0.0) -> tuple[PhaseNLP, dict]:
        """The NLP for the verified design ``ver`` and IPOPT's arguments from it (``x0``,
        ``lbx``, ``ubx``, ``lbg``, ``ubg``, ``p``): the start and bounds of one run."""
        nlp = self.nlp(ver.sequences)
        guess = start_guess(nlp, ver)
        lbx, ubx = nlp.bounds(guess, ver.sequences, ver.held)
        params = nlp.parameters(ver.sequences, ver.held)
        lbg, ubg = nlp.constraint_bounds(problem, ver.sequences, tightening, ver.held, guess)
        x0 = nlp.start(guess, lbx, ubx, params)
        params = nlp.with_picks(x0, params, ver.sequences)
        return nlp, dict(x0=x0, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg, p=params)

    def _ipopt(self, problem, ver: Verification, tightening: float, hessian: str,
               budget: int | None = None, warm: dict | None = None) -> "_Run":
        """One IPOPT run on the NLP from the verified design ``ver`` (stopped after ``budget``
        iterations when one is given). ``warm``: a neighbour's optimum (:attr:`Outcome.warm`);
        where it was found on this very NLP (the same slots, hand-over sequences and held
        slots: :func:`warm_signature`), the run starts from its primal-dual solution with the
        exact Hessian and :data:`~optdesign.solver.nlp.WARM_OPTIONS`."""
        nlp, args = self.ipopt_arguments(problem, ver, tightening)
        lbx, ubx, lbg, ubg, params = (args[k] for k in ("lbx", "ubx", "lbg", "ubg", "p"))
        signature = warm_signature(nlp, ver)
        warm = warm if warm is not None and warm.get("signature") == signature else None
        if warm is not None:
            hessian = "exact"
            budget = WARM_BUDGET if budget is None else min(budget, WARM_BUDGET)
            args = args | {"x0": np.clip(np.asarray(warm["x"], float), lbx, ubx),
                           "lam_x0": np.asarray(warm["lam_x"], float),
                           "lam_g0": np.asarray(warm["lam_g"], float)}
        with self.timings.stage("build"):
            solver = nlp.solver(hessian, warm=warm is not None)
        nlp.watch.start([np.array([v[k] for k in nlp.free]) / nlp.scale for v in self.avoid],
                        lbg, ubg, None if budget is None else max(budget, 1))
        with self.timings.stage("ipopt"), interrupts_kept():   # CasADi swallows Ctrl-C
            sol = solver(**args)
        stats = solver.stats()
        x = np.array(sol["x"]).ravel()
        joined = nlp.watch.joined
        status = JOINED if joined else STALLED if nlp.watch.stalled else \
            EXHAUSTED if nlp.watch.exhausted else stats["return_status"]
        return _Run(status=status, warm=warm is not None,
                    primal_dual={"signature": signature, "x": x.tolist(),
                                 "lam_x": np.array(sol["lam_x"]).ravel().tolist(),
                                 "lam_g": np.array(sol["lam_g"]).ravel().tolist()},
                    iterations=int(stats["iter_count"]),
                    lengths=nlp.lengths_of(x), surrogate=nlp.worst_ripple(x, params, ver.held),
                    multiplier=nlp.multiplier(sol["lam_g"], "min_ratio"),
                    binding_parts=nlp.binding_scenarios(sol["lam_g"], ver.held),
                    at_window=nlp.at_window_bound(x, lbx, ubx),
                    picks_moved=nlp.picks_moved(x, params, ver.sequences),
                    at_rest=nlp.output_at_rest(x, sol["lam_x"]),
                    binding="" if joined else nlp.binding(np.array(sol["g"]).ravel(), lbg, ubg),
                    active=nlp.active_set(problem, x, sol["lam_x"], sol["lam_g"], lbx, ubx))


@dataclass
class _Run:
    """What one IPOPT run returned, read off the NLP by name."""

    status: str
    iterations: int
    lengths: dict
    surrogate: float
    multiplier: float
    at_window: bool
    binding: str
    active: list            # what binds at the solution, with d objective / d bound
    binding_parts: tuple = ()   # a robust solve's held parts that bind (their offsets)
    picks_moved: bool = False   # an attained form's worst candidate moved (NLP.picks_moved)
    at_rest: bool = False       # the output comes to rest once a turn (NLP.output_at_rest)
    #: where the run ended, for a neighbour's warm start (:attr:`Outcome.warm`)
    primal_dual: dict | None = None
    warm: bool = False          # the run started from a neighbour's primal-dual optimum


def warm_signature(nlp: PhaseNLP, ver: Verification) -> str:
    """What a primal-dual solution's meaning rests on: the NLP (count, slots, sizes), the
    hand-over sequences and the held slots its run was given. A warm start is taken only
    on an equal signature, so ``x`` and the multipliers index the same variables and rows."""
    text = repr((nlp.count, nlp.slots, nlp.n_x, nlp.n_g, ver.sequences, ver.held))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _in_objective_units(problem, active: list[dict], ver: Verification) -> list[dict]:
    """The active set's sensitivities in the objective's units (the NLP may minimise another
    figure of it: cos²μ for the largest least angle)."""
    if ver.measured is None:
        return active
    scale = objective_of(problem).per_nlp_unit(ver.measured)
    return active if scale == 1.0 else [a | {"sensitivity": a["sensitivity"] * scale}
                                        for a in active]


def tightened(problem, bound):
    """``problem`` with its bound of ``bound``'s quantity (at the same eccentricity)
    intersected with ``bound``."""
    specs, found = [], False
    for spec in problem.quantity_bounds:
        if spec.key == bound.key:
            spec = replace(spec, lower=max(spec.lower, bound.lower),
                           upper=min(spec.upper, bound.upper))
            found = True
        specs.append(spec)
    if not found:
        specs.append(bound)
    return problem.with_quantity_bounds(specs)


def next_held(problem, ver: Verification) -> Held:
    """The eccentricity slots for the next solve of a design verified with ``ver.held``: the
    same, unless the worst δ inside the regulation interval exceeds the worst at the held
    eccentricities (the listed ones and the active slots) by more than REGULATION_TOL, or the
    least transmission angle inside it breaks the bound where no held eccentricity sees it,
    or a quantity a criterion reads over the interval is worse inside it than at every held
    eccentricity (:func:`_quantities_wanted`); then that eccentricity is held: in the slot of
    a held one close to it, else in an idle slot, else in place of the held slot of least δ."""
    held, ev = ver.held, ver.evaluation
    if not held.eccentricities or ev is None or ev.worst is None:
        return held
    worst, definition = ev.worst, problem.objective.ripple
    lower, upper = problem.eccentricity_range
    n_fixed = len(ev.per_e) - len(held.eccentricities)
    rows = [(x.eccentricity, x.figures[ev.stroke].ripple(definition), x.min_angle_deg)
            for i, x in enumerate(ev.per_e)
            if (i < n_fixed and x.eccentricity in problem.eccentricities)
            or (i >= n_fixed and held.active[i - n_fixed])]
    wanted = []
    if worst.interior(worst.eccentricity) and \
            worst.delta > max(r[1] for r in rows) + REGULATION_TOL:
        wanted.append((worst.eccentricity, worst.delta))
    bound = problem.constraints.min_transmission_angle_deg
    if worst.interior(worst.angle_eccentricity) and \
            worst.min_angle_deg < bound - TOL_ANGLE_DEG and \
            worst.min_angle_deg < min(r[2] for r in rows) - TOL_ANGLE_DEG:
        wanted.append((worst.angle_eccentricity, worst.points[worst.angle_eccentricity][0]))
    wanted += _quantities_wanted(problem, ev, [r[0] for r in rows])
    if not wanted:
        return held
    es, active = list(held.eccentricities), list(held.active)
    deltas = [ev.per_e[n_fixed + j].figures[ev.stroke].ripple(definition)
              for j in range(len(es))]
    placed: set[int] = set()
    for e, delta in wanted:
        near = [j for j in range(len(es)) if active[j] and j not in placed
                and abs(es[j] - e) <= SAME_SLOT * (upper - lower)]
        idle = [j for j in range(len(es)) if not active[j] and j not in placed]
        others = sorted((j for j in range(len(es)) if j not in placed), key=lambda j: deltas[j])
        j = (near or idle or others or [None])[0]
        if j is None:
            break
        es[j], active[j], deltas[j] = e, True, delta
        placed.add(j)
    return Held(tuple(es), tuple(active))


def _quantities_wanted(problem, ev, held_es) -> list[tuple[float, float]]:
    """(e, δ there) of each quantity a criterion reads over the regulation interval whose
    interval worst lies inside it and is worse than at every held eccentricity ``held_es``
    by more than the bound's tolerance, where it matters: the objective's quantity always, a
    bounded one when the interval's worst breaks the bound."""
    worst, out = ev.worst, []
    objective = objective_of(problem)
    bounds = {s.name: s for s in problem.quantity_bounds if s.at is None}
    for name in interval_quantities(problem):
        e, value = worst.quantities[name]
        q = get_quantity(name)
        sign = 1.0 if q.worst == "max" else -1.0
        seen = max(sign * q.exact(ev, x, problem.objective.ripple) for x in held_es)
        if not worst.interior(e) or sign * value <= seen + quantity_tolerance(value):
            continue
        spec = bounds.get(name)
        breaks = spec is not None and bound_excess(spec, value) > 0
        if breaks or getattr(objective, "quantity", None) == name:
            out.append((e, worst.points.get(e, (np.inf,))[0]))
    return out


def _same_cycles(a, b) -> bool:
    """The hand-over sequences of every eccentricity are the same cycles: equal up to where
    the turn starts (a hand-over that moved across φ = 0 changes the first curve of the
    list, not the NLP's structure)."""
    def rotations(seq):
        return {tuple(seq[i:]) + tuple(seq[:i]) for i in range(len(seq))} or {()}

    return len(a) == len(b) and all(tuple(x) in rotations(y) for x, y in zip(a, b))

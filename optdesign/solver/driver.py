"""Screen, polish the best basins with IPOPT, verify exactly: every admissible phase count.

Per phase count: one NLP is built (:class:`~optdesign.solver.nlp.PhaseNLP`) and reused by every
start, refinement and Pareto point; the box is screened (:mod:`optdesign.solver.screening`)
and the best basins are polished by IPOPT; every optimum is re-verified exactly
(:mod:`optdesign.solver.verify`) and re-solved while its exact structure disagrees with the
NLP's (hand-over order, an angle on its window, the transmission angle dipping between
samples), while the worst eccentricity inside a regulation interval is not held (it is then
held in an eccentricity slot, :func:`next_held`), and in a robust solve while the tolerance
box's worst parts are not held (scenario slots, :mod:`optdesign.solver.robust`). The best
verified design wins.
"""
from __future__ import annotations

import time
from contextlib import contextmanager, nullcontext
from dataclasses import asdict, dataclass, replace

import numpy as np

from optdesign.envelope.sampled import STROKE_SIGNS
from optdesign.errors import AssemblyError, ProblemError
from optdesign.evaluation.regulation import quantities_over_range
from optdesign.evaluation.sensitivity import sensitivity_record
from optdesign.lifetime import interrupts_kept
from optdesign.numerics import lanes
from optdesign.quantities import design_quantities, get_quantity, unit_text
from optdesign.quantities.bounds import side_key
from optdesign.quantities.criteria import (LengthConstraint, bound_excess, constraints_of,
                                           interval_quantities, objective_of,
                                           quantity_specs, quantity_tolerance,
                                           searched_quantities)
from optdesign.solver import built, count_order
from optdesign.solver.accuracy import solve_accuracy
from optdesign.solver.nlp import Held, PhaseNLP, SECONDARY_BUDGET, is_robust
from optdesign.solver.reachable import reach_of
from optdesign.solver.refine import refine
from optdesign.solver.result import PhaseResult, SolveResult, StartRecord
from optdesign.solver.robust import (next_scenarios, robust_verdict, screened_cases,
                                     worst_cases)
from optdesign.solver.screening import Scored, line_seeds, of_decades, screen
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
#: screened designs checked exactly when no polish converges (best ranked first)
CHECKED_WHEN_STUCK = 16
#: re-solves with new held eccentricities (a regulation interval), besides MAX_REFINEMENTS
MAX_REGULATION_STEPS = 6
#: the worst δ inside the interval may exceed the held eccentricities' worst by this much
REGULATION_TOL = 1e-8
#: a new worst eccentricity this close (share of the interval) to a held one moves that slot
SAME_SLOT = 0.05
#: re-solves with new scenario parts (a robust solve), besides MAX_REFINEMENTS
MAX_ROBUST_STEPS = 6
ANGLE_SAFETY_DEG = 0.01
#: two polished optima are one basin when their designs differ by less than this (relative
#: to the box) and their objectives by less than SAME_KEY_REL
SAME_DESIGN = 1e-4
SAME_KEY_REL = 1e-6


@dataclass
class Timings:
    """Wall time per stage, seconds."""

    build: float = 0.0
    screening: float = 0.0
    ipopt: float = 0.0
    verification: float = 0.0
    #: of the stages' time above, the seconds spent in a process beside the solve's own, at
    #: the same time as it (the best basins polished at once: :meth:`_Polishing.basins`)
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
                   bound=None) -> Outcome:
        """IPOPT from one start; refined until the exact check agrees with the NLP's structure.

        ``min_ratio``, ``max_ripple`` and ``bound`` (a QuantityBound, tightening the problem's
        own bound of that quantity) move bounds for this solve only, as a Pareto point's ε.
        A quasi-Newton run that stalls (or runs out of iterations) is retried once with the
        exact Hessian, unless the start is ``secondary`` (a further basin polished beside the
        best one: a stalled run there is abandoned, not rescued)."""
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
        at_rest = False
        active: list = []
        tightening, hessian = 0.0, problem.solver.hessian
        refinements = regulation_steps = robust_steps = 0
        while refinements < MAX_REFINEMENTS:
            refinements += 1
            if not ver.sequences:
                note = ver.message
                break
            run = self._ipopt(problem, ver, tightening, hessian,
                              SECONDARY_BUDGET - iterations if secondary else None)
            status, surrogate, multiplier, active = (run.status, run.surrogate,
                                                     run.multiplier, run.active)
            at_rest = run.at_rest
            iterations += run.iterations
            trial = values | run.lengths
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
        return Outcome(record, ver, values, surrogate, at_rest)

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
               budget: int | None = None) -> "_Run":
        """One IPOPT run on the NLP from the verified design ``ver`` (stopped after ``budget``
        iterations when one is given)."""
        nlp, args = self.ipopt_arguments(problem, ver, tightening)
        lbx, ubx, lbg, ubg, params = (args[k] for k in ("lbx", "ubx", "lbg", "ubg", "p"))
        with self.timings.stage("build"):
            solver = nlp.solver(hessian)
        nlp.watch.start([np.array([v[k] for k in nlp.free]) / nlp.scale for v in self.avoid],
                        lbg, ubg, None if budget is None else max(budget, 1))
        with self.timings.stage("ipopt"), interrupts_kept():   # CasADi swallows Ctrl-C
            sol = solver(**args)
        stats = solver.stats()
        x = np.array(sol["x"]).ravel()
        joined = nlp.watch.joined
        status = JOINED if joined else STALLED if nlp.watch.stalled else \
            EXHAUSTED if nlp.watch.exhausted else stats["return_status"]
        return _Run(status=status,
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


class _Polishing:
    """The polishes of one phase count: their records, the distinct optima, the best."""

    def __init__(self, problem, count: int, solver: PhaseSolver, result: PhaseResult,
                 workers: int = 1):
        self.problem, self.count, self.solver, self.result = problem, count, solver, result
        self.workers = workers
        self.best: Outcome | None = None
        self.optima: list[Outcome] = []
        #: every polish's outcome, feasible or not (the verdict must agree with each)
        self.outcomes: list[Outcome] = []
        self.polished = 0
        self.improved_at = 0          # the polish that last improved on the best

    def polish(self, values: dict, ver: Verification | None = None) -> Outcome:
        """IPOPT from ``values`` (its start's check ``ver``, when done already), recorded: a
        secondary polish (with a budget, stopped where it stalls or joins) beside a converged
        optimum; without one, a polish of its own to the end. A known design (where a polish
        that did not converge stopped, the file's own) is a candidate, not an optimum: beside
        it a basin is polished in full (a box of decades, where the first polish runs out of
        iterations and every later one stalled under the budget)."""
        self.solver.avoid = [o.values for o in self.optima]
        try:
            outcome = self.solver.solve_from(dict(values), ver=ver,
                                             secondary=self.converged())
        finally:
            self.solver.avoid = []
        return self.record(outcome)

    def consider(self, outcome: Outcome) -> None:
        """A known design verified as it is (no polish): the best when it meets every
        constraint and beats the polished optima; never a basin a polish stops at."""
        if outcome.record.feasible and (self.best is None or
                                        outcome.verification.key < self.best.verification.key):
            self.result.starts.append(outcome.record)
            self.best = outcome

    def record(self, outcome: Outcome) -> Outcome:
        self.polished += 1
        self.outcomes.append(outcome)
        self.result.starts.append(outcome.record)
        self.result.iterations += outcome.record.iterations
        if _verified_end(outcome):
            # IPOPT stopped short (out of iterations, a restoration failure) at a design the
            # exact check accepts: a design the solve has seen, so a candidate as it is
            self.consider(_as_found(outcome))
        if outcome.record.feasible:
            if not any(_same_optimum(self.problem, outcome, o) for o in self.optima):
                self.optima.append(outcome)
            if self.best is None or outcome.verification.key < self.best.verification.key:
                if self.best is None or not _same_optimum(self.problem, outcome, self.best):
                    self.improved_at = self.polished
                self.best = outcome
        return outcome

    def apart(self) -> bool:
        """Whether the polishes so far ended apart: more than one optimum, or a polish that
        reached none (stalled, out of budget, infeasible). A count whose best basins lead to
        different places is multimodal, and its next basins are worth polishing. A polish
        stopped as it came near a known optimum (:data:`JOINED`) counts as one that reached
        none: it may only pass by (``tests/solve/test_basins_apart.py``: the second basin,
        polished knowing the first's optimum)."""
        return len(self.optima) > 1 or any(
            not r.feasible or r.ipopt_status not in SUCCESS + (JOINED,)
            for r in self.result.starts)

    def basins(self, seeds) -> None:
        """Polish the best basins' seeds: `basins` of them once one is feasible; with none
        feasible, on until `agree + 1` IPOPT verdicts of local infeasibility on one constraint
        (or `starts` polishes). Where the polishes end :meth:`apart`, on through the next
        basins until `basins` polishes in a row bring no better optimum (the screening's rank
        of a basin is the sampled value of its seed, not of its bottom, so the best basin may
        rank third or fourth).

        The best `basins` are polished as if at once, each after the first on a solver of its
        own that knows no optimum the others found (:func:`_polish_beside`): so a basin that
        would join the first's optimum only in passing runs to its end, and the answer does
        not depend on the worker count. With more than one worker they are polished at once:
        the first here, the next `workers - 1` each in a process forked beside it
        (:func:`_head_beside`), the rest here after it; each outcome is recorded in the
        screening's order, as if polished in turn. The later basins are polished in turn,
        each stopped once it joins an optimum found already; with more than one worker, the
        next one is begun beside each and kept where the turn would have polished it with the
        same knowledge (:meth:`_further`). Either way each polish is the one the single
        process makes, to the bit: only the time differs (``tests/solve/test_built.py``)."""
        s = self.problem.solver
        seeds = list(seeds)
        head = min(s.basins, s.starts, len(seeds))
        if head > 1:
            self._head([seed.values for seed in seeds[:head]])
            seeds = seeds[head:]
        self._further([seed.values for seed in seeds])

    def _head(self, starts: list[dict]) -> None:
        """The best basins' polishes as if at once (:meth:`basins`): the first here, the
        next ``workers - 1`` in processes forked beside it, the rest here after it."""
        others = starts[1:]
        if self.workers > 1:
            self.solver.prepare()           # built once, before the processes part
        at_once = _head_beside(self.problem, self.count, others[:self.workers - 1],
                               self.solver.checks_in_parallel)
        try:
            with lanes.threads(1) if at_once else nullcontext():
                self.polish(starts[0])
        except BaseException:
            for pending in at_once:
                pending.cancel()
            raise
        for k, values in enumerate(others):
            if k < len(at_once):
                outcome, timings, _ = at_once[k]()      # (its NLPs: its own solver's)
            else:
                outcome, timings = _polish_beside(self.problem, self.count, values,
                                                  self.solver.checks_in_parallel)
            self._record_made(outcome, timings, beside=k < len(at_once))

    def _further(self, starts: list[dict]) -> None:
        """The basins after the best ones, in the screening's order, while they can bring a
        better optimum (:meth:`basins`). With more than one worker, each polish here is
        joined by the next one's, begun in a process forked beside it with what the solve
        knows then (the optima found, the NLPs built): where this polish leaves that
        unchanged and the next one is due, its outcome is the one this process would
        have found (the same polish on the same memory), and is taken; else it is dropped
        and the next one polished here."""
        s = self.problem.solver
        ahead = None                # (the start's index, its polish beside, what it knew)
        try:
            for i, values in enumerate(starts):
                if self.polished >= s.starts:
                    return
                if self.best is not None and self.polished >= s.basins and (
                        not self.apart() or
                        self.polished - max(self.improved_at, s.basins) >= s.basins):
                    return       # agreed, or `basins` more polishes found nothing better
                if ahead is not None and ahead[0] == i and ahead[2] == self._known():
                    outcome = self._record_made(*ahead[1](), beside=True)
                    ahead = None
                else:
                    ahead = _dropped(ahead)
                    if self.workers > 1 and i + 1 < len(starts) and \
                            self.polished + 1 < s.starts:
                        ahead = (i + 1, self._polish_ahead(starts[i + 1]), self._known())
                    with lanes.threads(1) if ahead else nullcontext():
                        outcome = self.polish(values)
                verdicts = [r.note for r in self.result.starts
                            if r.ipopt_status == "Infeasible_Problem_Detected"]
                if self.best is None and outcome.record.note and \
                        verdicts.count(outcome.record.note) >= s.agree + 1:
                    return
        finally:
            _dropped(ahead)

    def _known(self) -> tuple:
        """What a polish of this count starts from besides its start: the optima found (it
        stops where it joins one, and is secondary once there is one) and the NLPs its
        solver holds (it takes the first with enough slots)."""
        return (tuple(id(o) for o in self.optima), self.solver.held_slots())

    def _polish_ahead(self, values: dict):
        """:meth:`polish` of ``values`` with what the solve knows now, begun in a process
        forked beside this one (:func:`optdesign.lifetime.beside`)."""
        from optdesign.lifetime import beside

        return beside(_polish_here, self.solver, values, [o.values for o in self.optima],
                      self.converged())

    def _record_made(self, outcome: Outcome, timings: Timings, built_slots=(),
                     beside: bool = False) -> Outcome:
        """The outcome of a polish made by another solver or (``beside``) in a process
        beside this one, recorded as this solver's own with its stage times (those made
        beside counted as such); the NLPs it came to hold are built here too, in its order,
        so that this solver holds what it would hold had the polish been made by it."""
        for slots in built_slots:
            self.solver.nlp_of(slots)
        self.solver.timings.add(timings)
        if beside:
            self.solver.timings.beside += timings.total()
        return self.record(outcome)

    def converged(self) -> bool:
        """Whether a polish of the count converged to a design that meets every constraint
        (an optimum: a record is feasible only where IPOPT succeeded and the check agrees)."""
        return bool(self.optima)

    def rescue(self) -> None:
        """Where no polish converged, each polish the secondary budget stopped (on its way:
        neither stalled nor joined to an optimum) is run again from its start to its end, in
        the screening's order, until one converges (within ``solver.starts`` polishes). The
        budget spares the time of a further basin beside an optimum found; with none found,
        the stopped polishes are the count's best leads (on a box of decades a basin whose
        polish needs 75 iterations is stopped at 50 while the first polish runs out of
        iterations)."""
        stopped = [o.record.start for o in self.outcomes
                   if o.record.ipopt_status == EXHAUSTED]
        for values in stopped:
            if self.converged() or self.polished >= self.problem.solver.starts:
                return
            self.polish(values)

    def lines(self) -> None:
        """Line screening through the best optimum: a basin beside its face is polished while
        it improves on the best (within the polish budget)."""
        tried: list[dict] = []
        while self.best is not None and self.polished < self.problem.solver.starts:
            with self.solver.timings.stage("screening"), lanes.threads(self.workers):
                beside = [c for c in line_seeds(self.problem, self.count, self.best.values)
                          if not any(_close(self.problem, c.values, t) for t in tried)]
            if not beside:
                return
            tried.append(beside[0].values)
            before = self.best.verification.key
            self.polish(beside[0].values)
            if self.best.verification.key >= before - SAME_KEY_REL * max(1e-3, abs(before)):
                return


def _verified_end(outcome: Outcome) -> bool:
    """Whether a polish that did not converge ended at a design of its own (not its start)
    that the exact check found feasible."""
    r = outcome.record
    return (not r.feasible and r.ipopt_status not in SUCCESS + (JOINED, STALLED, EXHAUSTED,
                                                                AS_IT_IS)
            and bool(outcome.verification.feasible) and outcome.values != r.start)


def _as_found(outcome: Outcome) -> Outcome:
    """The end of an unconverged polish as a known design (:data:`AS_IT_IS`)."""
    record = StartRecord(start=dict(outcome.values), ipopt_status=AS_IT_IS, iterations=0,
                         time_s=0.0, feasible=True, delta=outcome.verification.delta,
                         note=f"where a polish stopped ({outcome.record.ipopt_status}), "
                              f"verified as it is")
    return Outcome(record, outcome.verification, dict(outcome.values), None)


def _polish_beside(problem, count: int, values: dict,
                   checks_in_parallel: bool = False) -> tuple[Outcome, Timings]:
    """A further best basin's polish (``secondary``: with a budget) on a solver of its own,
    which knows no optimum found before (its NLPs the process's kept ones of exactly the
    slots it asks for, :mod:`optdesign.solver.built`); its outcome and stage times."""
    solver = _of_its_own(problem, count, checks_in_parallel)
    return solver.solve_from(dict(values), secondary=True), solver.timings


def _of_its_own(problem, count: int, checks_in_parallel: bool) -> "PhaseSolver":
    """A solver of the count that knows no optimum and holds no NLP yet."""
    solver = PhaseSolver(problem, count)
    solver.checks_in_parallel = checks_in_parallel
    return solver


def _head_beside(problem, count: int, starts: list[dict],
                 checks_in_parallel: bool = False) -> list:
    """:func:`_polish_beside` of each of ``starts``, each begun in a process forked now
    (:func:`optdesign.lifetime.beside`, :func:`_polish_here`): called, each waits for its
    outcome and stage times (computed here if its process is lost). The same polish as in
    this process, on the same memory: the outcome is the same to the bit."""
    from optdesign.lifetime import beside

    return [beside(_polish_here, _of_its_own(problem, count, checks_in_parallel), values, [],
                   True) for values in starts]


def _polish_here(solver: "PhaseSolver", values: dict, avoid: list[dict], secondary: bool):
    """``solver``'s polish of ``values`` (stopped where it joins one of ``avoid``), in a
    process forked for it, the compiled lanes on one thread (the cores are taken): its
    outcome, its stage times and the slots of the NLPs it came to hold, in their order."""
    before = solver.held_slots()
    solver.timings, solver.avoid = Timings(), avoid
    with lanes.threads(1):
        outcome = solver.solve_from(dict(values), secondary=secondary)
    return outcome, solver.timings, [k for k in solver.held_slots() if k not in before]


def _dropped(ahead) -> None:
    """End the process of a polish begun ahead (:meth:`_Polishing._further`), if any."""
    if ahead is not None:
        ahead[1].cancel()


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
    then polish the best basins (:meth:`_Polishing.basins`). ``neighbours``: optima of other
    phase counts, screened with the box (continuation: the optimum of a neighbouring count
    often lies in the best basin of this one, and ranks first when it does).
    ``sensitivities``: the optimum's block computed here, on the evaluation its polish verified (a solve of one count;
    otherwise :func:`summarized` computes the answer's alone). ``scored``: the count's box
    sample scored already (:func:`~optdesign.solver.screening.promise`), used where the
    screening has no neighbour to add.

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
    work = _Polishing(basins.problem, count, basins, result, workers)
    given = problem.start_values() | {problem.model.count_variable: count}
    relax = explain and not robust and bool(screening.seeds)
    reach = None
    if relax and screening.n_feasible == 0:
        # the bound most of the sample misses first
        missed = sorted(screening.missed, key=lambda n: -screening.missed[n])
        reach = _reach(problem, count, missed[0] if missed else None, workers, [given],
                       basins.timings)
        if reach is not None and reach.out_of_reach:
            result.timings = solver.timings.to_dict()
            return _infeasible(result, problem, count, reach)
    seeds = list(screening.seeds)
    if reach is not None and reach.design is not None:
        seeds.insert(0, _seed(problem, reach.design))   # meets every bound: polish it first
    work.basins(seeds)
    work.rescue()
    work.lines()
    if work.best is None and relax and reach is None:
        reach = _reach(problem, count, _binding_of(result), workers,
                       [given] + [o.values for o in work.outcomes], basins.timings)
        if reach is not None and reach.out_of_reach:
            result.timings = solver.timings.to_dict()
            return _infeasible(result, problem, count, reach)
        if reach is not None and reach.design is not None:
            work.polish(reach.design)
            work.consider(basins.as_it_is(reach.design))
    if not robust and _user_gave(problem):
        if work.best is None:           # no polish got there: polish from the user's design
            work.polish(given)
        work.consider(basins.as_it_is(given))
    if not robust:
        _screened_floor(work, screening, basins)
    result.screening |= {"polished": work.polished, "distinct_optima": len(work.optima)}
    if robust:
        solver.checks_in_parallel = workers > 1
        work = _from_nominal_optima(problem, count, solver, work, screening.seeds)
    result.timings = solver.timings.to_dict()
    if work.best is not None:
        return _fill(result, problem, work.best, sensitivities)
    if not screening.seeds:
        result.status, result.binding = "infeasible", "assembly"
        result.message = (f"no design within the bounds assembles at every listed "
                          f"eccentricity with {count} phases")
        return result
    result = _no_optimum(result, problem)
    if reach is not None:
        result.reachable = reach.to_dict()
    return result


def _screened_floor(work: "_Polishing", screening, solver: PhaseSolver) -> None:
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


def _user_gave(problem) -> bool:
    """Whether the file gives a design of its own: every length fixed, or an initial value of
    a free one (without any, the start is only the middle of the box)."""
    free = [problem.design[k] for k in problem.free_lengths()]
    return not free or any(v.initial is not None for v in free)


def _reach(problem, count: int, binding, workers: int, known, timings: Timings):
    """:func:`~optdesign.solver.reachable.reach_of` the count, its time the screening's."""
    with timings.stage("screening"):
        return reach_of(problem, count, binding, solve_phase, workers, known)


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


def _from_nominal_optima(problem, count: int, solver: PhaseSolver, nominal: "_Polishing",
                         seeds) -> "_Polishing":
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
    work = _Polishing(problem, count, solver, result)
    for optimum in sorted(nominal.optima, key=lambda o: o.verification.key):
        if work.best is not None and \
                optimum.verification.key >= work.best.verification.key:
            break
        work.polish(optimum.values)
    if work.best is None and nominal.optima:
        work.basins(seeds)
    result.screening |= {"robust_polished": work.polished}
    return work


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


def _close(problem, a: dict, b: dict, share: float = 1e-3) -> bool:
    """Every free length of ``a`` and ``b`` within ``share`` of its box."""
    return all(abs(a[k] - b[k]) <= share * (problem.design[k].upper - problem.design[k].lower)
               for k in problem.free_lengths())


def _same_optimum(problem, a: Outcome, b: Outcome) -> bool:
    ka, kb = a.verification.key, b.verification.key
    return _close(problem, a.values, b.values, SAME_DESIGN) and \
        abs(ka - kb) <= SAME_KEY_REL * max(1e-3, abs(kb))


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


def _fill(result: PhaseResult, problem, outcome: Outcome,
          sensitivities: bool = False) -> PhaseResult:
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
    if sensitivities:           # on the evaluation at hand
        result.sensitivities = sensitivity_record(problem, design, ver.evaluation)
    result.quantities = design_quantities(problem, _every_quantity_searched(problem,
                                                                            ver.evaluation))
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

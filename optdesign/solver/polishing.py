"""Which starts of one phase count are polished, and in what order: the best basins, then
the next while they can bring a better optimum (:meth:`Polishing.basins`).

The best basins are polished as if at once, so the answer does not depend on the worker
count; with two cores the first is polished here and the next in a process beside it (a
child kept for the polishes beside, which holds their NLPs, else one forked for it:
:mod:`optdesign.kept_children`), and each later basin is begun beside the one before it. Each
polish is a :class:`~optdesign.solver.phase_solver.PhaseSolver`'s; the distinct optima it
finds, the best of them and every polish's record are this module's.
"""
from __future__ import annotations

from contextlib import nullcontext
from functools import partial

from optdesign.evaluation.design import Design
from optdesign import kept_children
from optdesign.envelope.sampled import STROKE_SIGNS
from optdesign.evaluation.figures import eccentricities_of, follow, generation, remember
from optdesign.numerics import lanes
from optdesign.quantities import design_quantities
from optdesign.solver.accuracy import refined_figures
from optdesign.solver import built
from optdesign.solver.phase_solver import (AS_IT_IS, EXHAUSTED, JOINED, STALLED, SUCCESS,
                                           Outcome, PhaseSolver, Timings)
from optdesign.solver.result import PhaseResult, StartRecord
from optdesign.solver.screening import LineScreening
from optdesign.solver.verify import Verification

#: two polished optima are one basin when their designs differ by less than this (relative
#: to the box) and their objectives by less than SAME_KEY_REL
SAME_DESIGN = 1e-4
SAME_KEY_REL = 1e-6


class Polishing:
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
        #: designs a later step of the solve checks exactly as they are (the file's own):
        #: checked by the process beside the first polish once its polish is done
        #: (:meth:`_head`), or else while this process waits for one (:meth:`_awaited`)
        self.checked_later: list[dict] = []
        #: whether this count's best optimum is the one whose records the solve makes (its
        #: quantities; refined for the accuracy record, should it be the solve's answer:
        #: :func:`~optdesign.solver.accuracy.solve_accuracy`), not a nominal problem's
        self.records_later = False
        #: the optimum whose quantities a wait made ahead, if any (:meth:`_quantities_ahead`)
        self.quantities_made: Outcome | None = None
        #: the line screening through the last design it was asked for (:meth:`_lines_through`)
        self._lines: LineScreening | None = None
        #: the first line polish, made while a wait for a further basin's polish beside had
        #: nothing else to make (:meth:`_line_polish_ahead`), with what it knew
        self._line_ahead: tuple | None = None

    def polish(self, values: dict, ver: Verification | None = None) -> Outcome:
        """IPOPT from ``values`` (its start's check ``ver``, when done already), recorded: a
        secondary polish (with a budget, stopped where it stalls or joins) beside a converged
        optimum; without one, a polish of its own to the end. A known design (where a polish
        that did not converge stopped, the file's own) is a candidate, not an optimum: beside
        it a basin is polished in full (a box of decades, where the first polish runs out of
        iterations and every later one stalled under the budget)."""
        return self.record(self._polished(values, ver))

    def _polished(self, values: dict, ver: Verification | None = None) -> Outcome:
        """:meth:`polish`'s outcome, not recorded."""
        self.solver.avoid = [o.values for o in self.optima]
        try:
            return self.solver.solve_from(dict(values), ver=ver, secondary=self.converged())
        finally:
            self.solver.avoid = []

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
        reached a place of its own short of an optimum (out of budget, infeasible, stopped
        elsewhere). A count whose best basins lead to different places is multimodal, and
        its next basins are worth polishing. A polish stopped as it came near a known
        optimum (:data:`JOINED`) counts as one that reached none: it may only pass by
        (``tests/solve/test_basins_apart.py``: the second basin, polished knowing the
        first's optimum). A polish still far from feasible after its first iterations
        (:data:`STALLED`) does not: it reached no place at all, and says nothing of where
        its basin leads (the disc problem at four phases: its second basin stalls, and the
        two next basins polished for it joined the first's optimum and stalled again)."""
        return len(self.optima) > 1 or any(
            r.ipopt_status != STALLED and
            (not r.feasible or r.ipopt_status not in SUCCESS + (JOINED,))
            for r in self.result.starts)

    def basins(self, seeds, leads: int = 1) -> None:
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
        process makes, to the bit: only the time differs (``tests/solve/test_built.py``).
        The first ``leads`` of the best basins are each polished to their end, the others
        beside them with the secondary budget (two leads where the screening's feasibility
        stage added designs to a box sample that passed a few:
        :attr:`~optdesign.solver.screening.Screening.leads`)."""
        s = self.problem.solver
        seeds = list(seeds)
        head = min(s.basins, s.starts, len(seeds))
        if head > 1:
            self._head([seed.values for seed in seeds[:head]], leads)
            seeds = seeds[head:]
        self._further([seed.values for seed in seeds])

    def _head(self, starts: list[dict], leads: int = 1) -> None:
        """The best basins' polishes as if at once (:meth:`basins`): the first here, the
        next ``workers - 1`` in processes forked beside it, the rest here after it; the
        first ``leads`` each to its end, the others with the secondary budget."""
        others = starts[1:]
        secondary = [k + 1 >= leads for k in range(len(others))]
        if self.workers > 1:
            self.solver.prepare()           # built once, before the processes part
        beside, handed = others[:self.workers - 1], []
        if beside:      # checked there once its polish is done (it often ends first)
            handed, self.checked_later = self.checked_later, []
        at_once = _head_beside(self.problem, self.count, beside,
                               self.solver.checks_in_parallel, handed, secondary)
        try:
            with lanes.threads(1) if at_once else nullcontext():
                self.polish(starts[0])
            made = [self._awaited(pending) for pending in at_once]
        except BaseException:
            for pending in at_once:         # (one taken already: nothing to end)
                pending.cancel()
            raise
        for outcome, timings, _, checked in made:      # (its NLPs: its own solver's)
            for evaluation in checked:
                remember(self.problem, evaluation)
            self._record_made(outcome, timings, beside=True)
        for k, values in enumerate(others[len(at_once):], start=len(at_once)):
            self._record_made(*_polish_beside(self.problem, self.count, values,
                                              self.solver.checks_in_parallel, secondary[k]))

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
                    outcome, timings, built_slots, _ = self._awaited(ahead[1], lines_ahead=True)
                    outcome = self._record_made(outcome, timings, built_slots, beside=True)
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

    def _awaited(self, pending, lines_ahead: bool = False):
        """The value of ``pending``, a polish in a process beside this one. Until it is in,
        this process makes, one at a time, what a later step of the solve will ask of it
        (:meth:`_while_waiting`; with ``lines_ahead``, a further basin's: the first line
        polish last): the same computations, on a core that would idle, which that step
        then finds made (the answer the same to the bit)."""
        try:
            pieces = self._while_waiting(lines_ahead)
            while not pending.ready():
                piece = next(pieces, None)
                if piece is None:
                    break
                with lanes.threads(1):          # the other core is the polish's
                    piece()
            return pending()
        except BaseException:
            pending.cancel()
            raise

    def _while_waiting(self, lines_ahead: bool = False):
        """What a wait for a polish beside can make ahead (:meth:`_awaited`), in turn: the
        exact check of each design a later step checks as it is that no process beside took
        (:attr:`checked_later`, kept in the evaluator's memory of checked designs); then, for
        the best optimum so far, the line screening through it (:meth:`lines`, kept for the
        design it was made for; a line at a time, so that a wait ends within a line's
        screening and the lines left share the cores) and, with :attr:`records_later`, its
        figures on the accuracy record's finer grid at each eccentricity (kept in the
        evaluator's memory) and its quantities (their maxima over the turn kept by each
        quantity): each used where that optimum is still the best when they are asked for;
        with ``lines_ahead`` (a further basin's polish awaited: a wait with little else to
        make), the first polish of :meth:`lines` last (:meth:`_line_polish_ahead`)."""
        while self.checked_later:
            yield partial(self.solver.as_it_is, self.checked_later.pop(0))
        if self.best is None:
            return
        if self.polished < self.problem.solver.starts:
            screening = self._lines_through(self.best.values)
            for _ in range(screening.remaining):
                yield partial(self._line_step, screening)
        if self.records_later:
            design = Design.from_problem(self.problem, self.best.values)
            for e in eccentricities_of(self.problem):
                yield partial(self._refined, design, e)
            yield partial(self._quantities_ahead, self.best)
        if lines_ahead and self.polished + 1 < self.problem.solver.starts:
            yield partial(self._line_polish_ahead, self.best)

    def _lines_through(self, values: dict) -> LineScreening:
        """The :class:`~optdesign.solver.screening.LineScreening` through ``values``, made once
        for the last design asked for (the lines screened so far kept)."""
        if self._lines is None or not self._lines.passes_through(values):
            self._lines = LineScreening(self.problem, self.count, values)
        return self._lines

    def _line_step(self, screening: LineScreening) -> None:
        """One more line of ``screening`` (:meth:`_while_waiting`)."""
        with self.solver.timings.stage("screening"):
            screening.step()

    def _line_seeds(self, values: dict) -> list:
        """The line screening's seeds through ``values``, its lines not screened yet
        screened now."""
        with self.solver.timings.stage("screening"):
            return self._lines_through(values).seeds()

    def _quantities_ahead(self, best: Outcome) -> None:
        """``best``'s quantities, made ahead (:func:`design_quantities` keeps the maxima they
        read); :attr:`quantities_made` names the optimum whose they are."""
        design_quantities(self.problem, best.verification.evaluation)
        self.quantities_made = best

    def _line_polish_ahead(self, best: Outcome) -> None:
        """The polish :meth:`lines` begins with (its first seed through ``best``), made
        now, with what the solve knows now: :meth:`lines` takes its outcome where the solve
        still knows just that (the same best, the same optima, the same NLPs held; nothing
        built by the polish itself), so it is the polish the turn makes, to the bit."""
        if self.best is not best or self._lines_through(best.values).remaining:
            return
        seeds = self._line_seeds(best.values)
        if not seeds:
            return
        known = self._known()
        outcome = self._polished(seeds[0].values)
        if self._known() == known:
            self._line_ahead = (best, known, seeds[0].values, outcome)

    def _taken_ahead(self, values: dict) -> Outcome | None:
        """The line polish of ``values`` made ahead (:meth:`_line_polish_ahead`) where the
        solve knows what it knew then, else None; let go of either way."""
        ahead, self._line_ahead = self._line_ahead, None
        if ahead is None or ahead[0] is not self.best or ahead[1] != self._known() or \
                ahead[2] != values:
            return None
        return ahead[3]

    def _refined(self, design, e: float) -> None:
        """``design``'s figures at ``e`` on the accuracy record's finer grid, made ahead
        (:func:`~optdesign.solver.accuracy.refined_figures` keeps them)."""
        with self.solver.timings.stage("verification"):
            refined_figures(self.problem, design, e)

    def _known(self) -> tuple:
        """What a polish of this count starts from besides its start: the optima found (it
        stops where it joins one, and is secondary once there is one) and the NLPs its
        solver holds (it takes the first with enough slots)."""
        return (tuple(id(o) for o in self.optima), self.solver.held_slots())

    def _polish_ahead(self, values: dict):
        """:meth:`polish` of ``values`` with what the solve knows now, begun in a process
        beside this one (:func:`_beside`)."""
        return _beside(self.problem, self.count, self.solver.held_slots(),
                       self.solver.checks_in_parallel, values,
                       [o.values for o in self.optima], self.converged())

    def _record_made(self, outcome: Outcome, timings: Timings, built_slots=(),
                     beside: bool = False) -> Outcome:
        """The outcome of a polish made by another solver or (``beside``) in a process
        beside this one, recorded as this solver's own with its stage times (those made
        beside counted as such); the NLPs it came to hold are built here too, in its order,
        so that this solver holds what it would hold had the polish been made by it, and the
        exact check it ended on is kept in this process's memory of checked designs (a later
        check of that design, the answer's accuracy record, reads it)."""
        for slots in built_slots:
            self.solver.nlp_of(slots)
        self.solver.timings.add(timings)
        if beside:
            self.solver.timings.beside += timings.total()
            if outcome.verification.evaluation is not None:   # its end's exact check
                remember(self.problem, outcome.verification.evaluation)
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
            with lanes.threads(self.workers):
                seeds = self._line_seeds(self.best.values)
            beside = [c for c in seeds if not any(_close(self.problem, c.values, t)
                                                  for t in tried)]
            if not beside:
                return
            tried.append(beside[0].values)
            before = self.best.verification.key
            made = self._taken_ahead(beside[0].values) if len(tried) == 1 else None
            if made is not None:
                self.record(made)
            else:
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


def _polish_beside(problem, count: int, values: dict, checks_in_parallel: bool = False,
                   secondary: bool = True) -> tuple[Outcome, Timings]:
    """A further best basin's polish (``secondary``: with a budget) on a solver of its own,
    which knows no optimum found before (its NLPs the process's kept ones of exactly the
    slots it asks for, :mod:`optdesign.solver.built`); its outcome and stage times."""
    solver = _of_its_own(problem, count, checks_in_parallel)
    return solver.solve_from(dict(values), secondary=secondary), solver.timings


def _of_its_own(problem, count: int, checks_in_parallel: bool) -> "PhaseSolver":
    """A solver of the count that knows no optimum and holds no NLP yet."""
    solver = PhaseSolver(problem, count)
    solver.checks_in_parallel = checks_in_parallel
    return solver


def _head_beside(problem, count: int, starts: list[dict], checks_in_parallel: bool = False,
                 checks: list[dict] = (), secondary=None) -> list:
    """:func:`_polish_beside` of each of ``starts`` (``secondary``: whether each has the
    secondary budget; each has by default), each begun in a process beside this one
    (:func:`_beside`, :func:`_polish_here`): called, each waits for its outcome and stage
    times (computed here if its process is lost). The same polish as in this process, on
    the same NLPs: the outcome is the same to the bit. The first also
    checks ``checks`` as they are, once its polish is done."""
    secondary = [True] * len(starts) if secondary is None else secondary
    return [_beside(problem, count, (), checks_in_parallel, values, [], secondary[k],
                    checks if k == 0 else ())
            for k, values in enumerate(starts)]


def _beside(problem, count: int, held: tuple, checks_in_parallel: bool, values: dict,
            avoid: list[dict], secondary: bool, checks=()):
    """:func:`_polish_here` of ``values`` by a solver of the count that holds the NLPs of
    ``held`` slots (in that order), begun in a process beside this one: a child kept for
    such polishes that holds those NLPs and the one of a slot per curve
    (:func:`optdesign.kept_children.beside`), else one forked now, which inherits every NLP
    this process holds (:mod:`optdesign.solver.built`). The same polish as here."""
    return kept_children.beside(_polish_of, problem, count, tuple(held), checks_in_parallel,
                                values, avoid, secondary, tuple(checks), generation(),
                                needs=_nlps_named(problem, count, held), inherits=built.held)


def _nlps_named(problem, count: int, held: tuple = ()) -> set:
    """The names (:func:`optdesign.solver.built.held`'s) of the count's NLPs of ``held``
    slots and of the one of a slot per curve: what a child a polish is asked of holds."""
    key = built.key_of(problem, count)
    curves = count * len(STROKE_SIGNS[problem.stroke])
    return {(key, slots) for slots in (*held, curves)}


def answer_record_beside(problem, count: int, fn, *args, builds=None,
                         built_there: bool = False):
    """``fn(*args)`` (a record of the answer, computed from data alone) begun in a kept
    child that holds the count's NLP and is idle (:func:`optdesign.kept_children.beside`:
    the one its polishes beside ran in, which holds the count's functions built), for this
    process to make the rest meanwhile; None where there is none (the caller computes it).
    ``builds``: the name of what computing it builds (the child holds it afterwards);
    ``built_there``: only a child that holds that already."""
    needs = _nlps_named(problem, count)
    gains = set() if builds is None else {builds}
    return kept_children.beside(_record_of, generation(), fn, args, fork=False,
                                needs=needs | gains if built_there else needs, gains=gains)


def _record_of(forgotten: tuple, fn, args):
    follow(forgotten)
    with lanes.threads(1):                  # the other core is the asking process's
        return fn(*args)


def _polish_of(problem, count: int, held: tuple, checks_in_parallel: bool, values: dict,
               avoid: list[dict], secondary: bool, checks: tuple, forgotten: tuple):
    """:func:`_polish_here` by a solver of the count holding the NLPs of ``held`` slots, in
    that order (in a kept child: its own, :mod:`optdesign.solver.built`), the evaluator's
    memory emptied first where the process that asked emptied its own since this one last
    did (``forgotten``: its :func:`~optdesign.evaluation.figures.generation`)."""
    follow(forgotten)
    solver = _of_its_own(problem, count, checks_in_parallel)
    for slots in held:
        solver.nlp_of(slots)
    return _polish_here(solver, values, avoid, secondary, checks)


def _polish_here(solver: "PhaseSolver", values: dict, avoid: list[dict], secondary: bool,
                 checks: list[dict] = ()):
    """``solver``'s polish of ``values`` (stopped where it joins one of ``avoid``), in a
    process forked for it, the compiled lanes on one thread (the cores are taken): its
    outcome, its stage times, the slots of the NLPs it came to hold, in their order, and
    the exact check (:meth:`PhaseSolver.as_it_is`) of each of ``checks``, made after it,
    for the process that forked it to remember
    (:func:`optdesign.evaluation.figures.remember`)."""
    before = solver.held_slots()
    solver.timings, solver.avoid = Timings(), avoid
    with lanes.threads(1):
        outcome = solver.solve_from(dict(values), secondary=secondary)
        checked = [solver.as_it_is(v).verification.evaluation for v in checks]
    return (outcome, solver.timings, [k for k in solver.held_slots() if k not in before],
            [e for e in checked if e is not None])


def _dropped(ahead) -> None:
    """End the process of a polish begun ahead (:meth:`Polishing._further`), if any."""
    if ahead is not None:
        ahead[1].cancel()


def _close(problem, a: dict, b: dict, share: float = 1e-3) -> bool:
    """Every free length of ``a`` and ``b`` within ``share`` of its box."""
    return all(abs(a[k] - b[k]) <= share * (problem.design[k].upper - problem.design[k].lower)
               for k in problem.free_lengths())


def _same_optimum(problem, a: Outcome, b: Outcome) -> bool:
    ka, kb = a.verification.key, b.verification.key
    return _close(problem, a.values, b.values, SAME_DESIGN) and \
        abs(ka - kb) <= SAME_KEY_REL * max(1e-3, abs(kb))

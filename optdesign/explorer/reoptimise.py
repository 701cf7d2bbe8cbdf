"""Re-optimisation from the design on screen: IPOPT warm-started on an NLP built once.

A solve (:func:`optdesign.solver.driver.solve`) screens the whole box and polishes its best
basins; the explorer asks a smaller question, "where does the optimum go from here?", and
answers it with one polish (:meth:`optdesign.solver.phase_solver.PhaseSolver.solve_from`) from the
current design, refined until the exact evaluator agrees with the NLP, as every polish is.

The NLP of a phase count is built once and kept: the constraints' bounds are read from the
problem of each solve (:meth:`optdesign.quantities.criteria.Constraint.bounds`), so a moved
bound re-solves on the same NLP. Only a change of the NLP's structure builds a new one: a
bound switched on or off (a least ratio from 0 to 0.3, a ripple cap given or removed).
"""
from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass, field

from optdesign.explorer.bounds import bounds_of


@dataclass(frozen=True)
class Reoptimised:
    """One re-optimisation: where it ended and what binds there."""

    status: str                 # "optimal" when the exact check passed, else "not optimal"
    values: dict                # the design it ended on (every design key)
    delta: float | None
    iterations: int
    time_s: float
    binding: str                # optdesign.solver.outputs.binding_text's line
    message: str = ""
    active: list = field(default_factory=list)

    @property
    def line(self) -> str:
        """One line for the page."""
        head = (f"re-optimised: {self.status}, δ = {self.delta:.6f}" if self.delta is not None
                else f"re-optimised: {self.status}")
        tail = f"; {self.message}" if self.message else ""
        return f"{head} ({self.iterations} IPOPT iterations, {self.time_s:.2f} s){tail}"


def structure(problem) -> tuple:
    """What fixes the NLP beside the bounds' values: which bounds are on (a zero floor, an
    absent cap or an infinite side builds no row of its own)."""
    return tuple((b.key, b.value != 0 and math.isfinite(b.value)) for b in bounds_of(problem))


class Reoptimiser:
    """Keeps one :class:`~optdesign.solver.phase_solver.PhaseSolver` (with its built NLPs and
    IPOPT functions) per phase count and NLP structure; one solve at a time."""

    def __init__(self):
        self._solvers: dict[tuple, object] = {}
        self._lock = threading.Lock()

    def _solver(self, problem, count: int):
        from optdesign.solver.phase_solver import PhaseSolver

        key = (count, structure(problem))
        solver = self._solvers.get(key)
        if solver is None:
            solver = self._solvers[key] = PhaseSolver(problem, count)
        solver.problem = problem        # this solve's bounds; the NLP reads them per solve
        return solver

    def prepare(self, problem, values: dict) -> None:
        """Build the NLP and its IPOPT function for ``values``' count ahead of the first
        re-optimisation (what a server does while the page is first drawn)."""
        with self._lock:
            solver = self._solver(problem, int(values[problem.model.count_variable]))
            nlp = solver.nlp([()])
            nlp.solver(problem.solver.hessian)

    def reoptimise(self, problem, values: dict) -> Reoptimised:
        """IPOPT from ``values`` (every design key) on ``problem``'s NLP of its count."""
        from optdesign.solver.outputs import binding_text

        count_key = problem.model.count_variable
        count = int(values[count_key])
        t0 = time.perf_counter()
        with self._lock:
            outcome = self._solver(problem, count).solve_from(dict(values))
        ver, record = outcome.verification, outcome.record
        ended = {k: float(outcome.values[k]) for k in problem.model.lengths} | {count_key: count}
        status = "optimal" if record.feasible else "not optimal"
        message = "" if record.feasible else (record.note or ver.message or
                                              f"IPOPT: {record.ipopt_status}")
        return Reoptimised(status=status, values=ended,
                           delta=ver.delta if ver.sequences else None,
                           iterations=record.iterations, time_s=time.perf_counter() - t0,
                           binding=binding_text(record.active, problem) if record.feasible
                           else "", message=message, active=list(record.active))

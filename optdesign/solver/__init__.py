"""How a problem is solved: NLP build (nlp), starts, IPOPT driver, exact re-verification.

A notebook calls :func:`optdesign.api.solve` (``from optdesign import solve``), which takes a
problem, a path or a mapping and validates it as the loader does; this package is its engine."""
from optdesign.solver.driver import PhaseSolver, solve, solve_phase
from optdesign.solver.result import PhaseResult, SolveResult, StartRecord
from optdesign.solver.verify import Verification, verify

__all__ = ["PhaseResult", "PhaseSolver", "SolveResult", "StartRecord", "Verification",
           "solve", "solve_phase", "verify"]

"""How a problem is solved: NLP build (nlp), starts, IPOPT driver, exact re-verification."""
from .driver import PhaseSolver, solve, solve_phase
from .result import PhaseResult, SolveResult, StartRecord
from .verify import Verification, verify

__all__ = ["PhaseResult", "PhaseSolver", "SolveResult", "StartRecord", "Verification",
           "solve", "solve_phase", "verify"]

"""How a problem is solved: NLP build (nlp), starts, IPOPT driver, exact re-verification.

The package is also the API's function: ``from optdesign import solve; solve(problem)`` calls
:func:`optdesign.api.solve` (a problem, a path or a mapping)."""
from .driver import PhaseSolver, solve, solve_phase
from .result import PhaseResult, SolveResult, StartRecord
from .verify import Verification, verify

__all__ = ["PhaseResult", "PhaseSolver", "SolveResult", "StartRecord", "Verification",
           "solve", "solve_phase", "verify"]

from ..callable_package import make_callable  # noqa: E402

make_callable(__name__, "solve")

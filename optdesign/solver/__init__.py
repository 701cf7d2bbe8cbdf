"""How a problem is solved: NLP build (nlp), starts, IPOPT driver, exact re-verification.

A notebook calls :func:`optdesign.api.solve` (``from optdesign import solve``), which takes a
problem, a path or a mapping and validates it as the loader does; this package is its engine.

The driver (and through it the screening) is imported when a name of it is first asked for:
``analyze`` reads :mod:`optdesign.solver.verify` and never solves. ``verify`` is bound here at
once, because it is also the name of a submodule, and a submodule imported later
would otherwise shadow the function on the package.
"""
from importlib import import_module

from optdesign.solver.verify import Verification, verify

__all__ = ["PhaseResult", "PhaseSolver", "SolveResult", "StartRecord", "Verification",
           "solve", "solve_phase", "verify"]

#: the names read from a submodule when first asked for
_LAZY = {"PhaseSolver": "optdesign.solver.phase_solver", "solve": "optdesign.solver.entry",
         "solve_phase": "optdesign.solver.driver", "PhaseResult": "optdesign.solver.result",
         "SolveResult": "optdesign.solver.result", "StartRecord": "optdesign.solver.result"}


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'optdesign.solver' has no attribute {name!r}")

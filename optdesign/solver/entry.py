"""The solve's one entry point: ``objective.minimize: phases`` (the least count for a ripple
cap, :mod:`optdesign.solver.least_count`) or any other objective, every admissible count
solved (:mod:`optdesign.solver.driver`)."""
from __future__ import annotations


def solve(problem, progress=None):
    """Solve ``problem`` as its objective asks; a
    :class:`~optdesign.solver.result.SolveResult`. ``progress``: called once per count
    solved."""
    if problem.objective.minimize == "phases":
        from optdesign.solver.least_count import least_count

        return least_count(problem, progress=progress)
    from optdesign.solver.driver import solve as every_count

    return every_count(problem, progress=progress)

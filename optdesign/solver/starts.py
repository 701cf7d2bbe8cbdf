"""Start designs for the multi-start: the file's own design first, then a scrambled Sobol
sample of the box of free lengths, kept only where the linkage assembles."""
from __future__ import annotations

import numpy as np

from optdesign.errors import AssemblyError, ProblemError
from optdesign.evaluation.design import Design
from optdesign.numerics import sobol


def assembles(design: Design, eccentricities) -> bool:
    try:
        design.model.check_values(design.values, design.count)
        for e in eccentricities:
            design.check_assembly(e, n_samples=360)
    except (AssemblyError, ProblemError):
        return False
    return True


def start_designs(problem, count: int, n_starts: int, max_tries: int = 512) -> list[Design]:
    """Up to ``n_starts`` assembling start designs for phase count ``count``."""
    base = problem.start_values() | {problem.model.count_variable: count}
    eccs = set(problem.eccentricities) | {1.0}
    free = problem.free_lengths()
    out = []
    first = Design.from_problem(problem, base)
    if assembles(first, eccs):
        out.append(first)
    if not free:
        return out[:1]
    lower = np.array([problem.design[k].lower for k in free])
    upper = np.array([problem.design[k].upper for k in free])
    points = sobol.scale(sobol.unit_sample(len(free), max_tries, problem.solver.seed),
                         lower, upper)
    for row in points:
        if len(out) >= n_starts:
            break
        d = Design.from_problem(problem, base | dict(zip(free, row)))
        if assembles(d, eccs):
            out.append(d)
    return out

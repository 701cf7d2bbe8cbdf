"""The largest count a user may give, one table for every way of giving it.

A count reaches the tool three ways: a problem (or atlas) file's key, a command-line flag and
an argument of the Python API. Each was once checked where it was read, with its own copy of
the limit, and one path had none: ``--workers 100000`` forked processes until the machine
stalled. Every reader now takes its upper bound from :data:`COUNTS`, so the file, the flag
and the API refuse the same values (docs/contract.md, "Limits").

A local pool is also held to the machine: however many workers are asked for (up to
``COUNTS["workers"]``, which a cluster may need), it starts at most
:data:`PROCESSES_PER_CORE` processes per core (:func:`local_processes`). Solving is CPU-bound:
more processes than cores only share them, a few per core absorb the time a worker spends
writing its outcome.
"""
from __future__ import annotations

import os

#: the largest value of each count a user gives, by the name the limit table in
#: docs/contract.md uses
COUNTS: dict[str, int] = {
    # worker processes: solver.workers, --workers of pareto and atlas, pareto(workers=...)
    "workers": 256,
    # ε values per phase count: pareto.points, --points, pareto(points=...); the refinement's
    # pareto.refine.max_points and hypervolume_points
    "points": 1000,
    # cells of one atlas, and values of one of its axes
    "cells": 100_000,
    "axis_values": 1000,
    # Monte Carlo parts: tolerances.samples, tolerance --samples
    "parts": 10_000_000,
    # crank samples: solver.samples (per turn, in the NLP), curves --samples (one curve)
    "nlp_samples": 2000,
    "curve_samples": 100_000,
    # frames of animate --frames
    "frames": 720,
    # crank turns simulated: dynamics.cycles, simulate --cycles (a day of computing, not a
    # typo's 1e9)
    "cycles": 100_000,
    # crank samples of bench --crosscheck (sampled in chunks: time grows, memory does not)
    "crosscheck": 100_000_000,
    # the solver's other counts (solver.screen, .starts, .basins, .agree, .max_iter)
    "screen": 65_536,
    "starts": 1000,
    "basins": 64,
    "agree": 100,
    "max_iter": 100_000,
}

#: most local worker processes per core (:func:`local_processes`)
PROCESSES_PER_CORE = 4


def cores() -> int:
    """The cores this process may run on (its affinity mask where the platform has one: a
    container's or ``taskset``'s share, not the machine's)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def local_processes(workers: int | None) -> int:
    """The processes a local pool starts for ``workers`` (None or 0: one per core): never more
    than :data:`PROCESSES_PER_CORE` per core, whatever was asked (a cluster's workers are the
    cluster's, not counted here)."""
    n = cores()
    return max(1, min(workers or n, PROCESSES_PER_CORE * n))

"""A local pool is held to the machine: whatever count of workers a file, a flag or the API
asks for, it starts at most PROCESSES_PER_CORE processes per core (optdesign/limits.py)."""
from dataclasses import replace

import pytest

from optdesign.limits import COUNTS, PROCESSES_PER_CORE, cores, local_processes
from optdesign.problem.loader import load_problem
from tests.conftest import ROOT


def test_a_local_pool_starts_at_most_a_few_processes_per_core():
    most = PROCESSES_PER_CORE * cores()
    assert local_processes(COUNTS["workers"]) == min(COUNTS["workers"], most)
    assert local_processes(10**6) == most
    assert local_processes(None) == local_processes(0) == cores()
    assert local_processes(1) == 1


@pytest.mark.parametrize("asked", [COUNTS["workers"], None])
def test_the_sweeps_pool_is_held_to_the_machine(asked):
    """The pool of pareto and atlas (one executor for both): the processes it may start are
    counted before any is forked (a pool forks on its first task)."""
    from optdesign.fronts.sweep import _executor

    ex = _executor(asked, None)
    try:
        started = getattr(getattr(ex, "pool", None), "_max_workers", 1)
        assert started == local_processes(asked) <= PROCESSES_PER_CORE * cores()
    finally:
        ex.close()


def test_the_polishes_are_held_to_the_machine():
    from optdesign.solver.driver import workers_for

    problem = load_problem(ROOT / "problems" / "sharkov2022_disc.yaml")
    many = replace(problem, solver=replace(problem.solver, workers=COUNTS["workers"]))
    assert workers_for(many) <= PROCESSES_PER_CORE * cores()

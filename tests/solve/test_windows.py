"""How far a tracked angle may move in one IPOPT run (optdesign/solver/nlp.py, ``bounds``): a
peak's and a hand-over's window is three curve spacings (at most 60°), an extreme of cos μ's
never less than 45° (``MU_MIN_HALF_WINDOW``: a chain's two extremes lie half a turn apart).
The disc problem at 24 phases: the second basin's extreme of cos μ moves 37° on its way,
more than three curve spacings (22.5°), which stopped its run at the window's edge and cost
a re-solve of 23 iterations. About 3 s."""
from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from optdesign.problem.loader import Variable, load_problem
from optdesign.solver.nlp import MU_MIN_HALF_WINDOW
from optdesign.solver.phase_solver import PhaseSolver, SUCCESS
from optdesign.solver.screening import screen

ROOT = Path(__file__).resolve().parents[2]
COUNT = 24


@pytest.fixture(scope="module")
def disc_24():
    problem = load_problem(ROOT / "problems" / "sharkov2022_disc.yaml")
    key = problem.model.count_variable
    return replace(problem, design={**problem.design, key: Variable(key, value=float(COUNT))})


def test_the_windows_of_peaks_and_extremes_of_cos_mu(disc_24):
    solver = PhaseSolver(disc_24, COUNT)
    ver = solver.verify(disc_24, disc_24.start_values(), search=False)
    nlp, args = solver.ipopt_arguments(disc_24, ver)
    half = {}
    for block in nlp.layout.x:
        if block.name.startswith(("phi_peak_", "phi_mu_")):
            width = (args["ubx"] - args["lbx"])[block.slice] / 2
            half[block.name.split("_e")[0]] = float(np.max(width))
    assert half["phi_peak"] == pytest.approx(3 * math.pi / nlp.n_curves)
    assert half["phi_mu"] == pytest.approx(MU_MIN_HALF_WINDOW)
    assert half["phi_peak"] < MU_MIN_HALF_WINDOW


def test_the_second_basin_is_polished_in_one_run(disc_24, monkeypatch):
    runs = []
    original = PhaseSolver._ipopt

    def counted(self, *args, **kwargs):
        run = original(self, *args, **kwargs)
        runs.append(run)
        return run

    monkeypatch.setattr(PhaseSolver, "_ipopt", counted)
    seeds = screen(disc_24, COUNT, disc_24.solver.screen).seeds
    outcome = PhaseSolver(disc_24, COUNT).solve_from(dict(seeds[1].values), secondary=True)
    assert outcome.record.ipopt_status in SUCCESS and outcome.record.feasible
    assert [r.at_window for r in runs] == [False]

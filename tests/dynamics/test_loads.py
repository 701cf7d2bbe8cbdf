"""Loads on the paper's dynamic case (problems/sharkov2022_dynamics.yaml): the freewheels' peak
torques and engagement shares and the joints' peak forces of the steady cycle, each checked
against a hand calculation written here."""
import math

import numpy as np
import pytest

from optdesign.dynamics.steady import simulate
from optdesign.evaluation.design import Design
from optdesign.problem.loader import load_problem
from tests.conftest import ROOT

FILE = ROOT / "problems" / "sharkov2022_dynamics.yaml"


@pytest.fixture(scope="module")
def run():
    problem = load_problem(FILE)
    return problem, simulate(problem)


def test_the_peak_freewheel_torque_is_lambda_times_eps_max(run):
    problem, result = run
    section = problem.sections["dynamics"]
    lam = section.stiffness_per_phase(6)[0]                 # 2877 N·m/rad, every freewheel
    wheels = result.loads["freewheels"]
    peak = max(w["peak_torque_n_m"] for w in wheels)
    # λ·ε_max by hand: 2877 N·m/rad × 0.0173 rad ≈ 50 N·m
    assert peak == pytest.approx(lam * result.eps_max, rel=1e-9)
    assert 45 < peak < 55
    # two of the six freewheels carry the load, as the paper's Fig. 3 shows
    assert sum(w["engaged_share"] > 0 for w in wheels) == 2
    assert all(0 <= w["engaged_share"] <= 1 for w in wheels)
    assert sum(w["engaged_share"] for w in wheels) <= 1 + 1e-9


def test_the_freewheels_carry_the_load_on_average(run):
    """Steady: the output's speed repeats, so ∫(Σ T_k − T_c) dt = I2·Δψ̇ = 0 over the cycle."""
    problem, result = run
    load = problem.sections["dynamics"].load
    assert result.loads["mean_freewheel_torque_n_m"] == pytest.approx(load, rel=1e-3)


def test_a_rod_carries_the_rockers_torque_over_its_arm(run):
    """Hand calculation for a rod C_iB_i (i >= 2), a two-force member: the rocker's torque M
    over its arm l3·sin μ, μ the transmission angle at B_i: F = M / (l3·sin μ), the same at
    the pin B_i, the disc's pin C_i and the rocker's pivot O_i."""
    problem, result = run
    design = Design.from_problem(problem)
    tr = result.trace
    torque = tr["freewheel_torque"][2]                      # freewheel 3, rocker 3
    busy = torque > 1.0
    cos_mu = design.sample(tr["phi"][busy])["cos_mu"][2]
    by_hand = torque[busy] / (design.values["l3"] / 1000.0 * np.sqrt(1.0 - cos_mu ** 2))
    forces = tr["joint_forces"]
    for joint in ("O3", "B3", "C3"):
        assert np.allclose(forces[joint][busy], by_hand, rtol=1e-9)
    peak = next(j for j in result.loads["joints"] if j["joint"] == "O3")
    assert peak["kind"] == "pivot" and peak["peak_force_n"] == pytest.approx(
        forces["O3"].max(), rel=1e-12)
    # a rocker whose freewheel never engages carries nothing
    assert np.all(forces["O5"] == 0.0)


def test_the_crank_pin_carries_the_crank_torque(run):
    """The crank O–A is massless: its torque is A×Q about O, at most l1·|Q|; by virtual work
    it equals Σ T_k·u_k' (the freewheels' reaction on the crank), so |Q| >= T / l1."""
    problem, result = run
    tr = result.trace
    from optdesign.dynamics.model import DriveModel
    model = DriveModel(Design.from_problem(problem), problem.stroke, problem.input_speed,
                       problem.sections["dynamics"])
    du = np.array([model.holders(p)[1] for p in tr["phi"]]).T
    crank = (tr["freewheel_torque"] * du).sum(axis=0)
    l1 = Design.from_problem(problem).values["l1"] / 1000.0
    assert np.all(tr["joint_forces"]["A"] >= np.abs(crank) / l1 * (1 - 1e-9))
    assert result.loads["peak_crank_torque_n_m"] == pytest.approx(crank.max(), rel=1e-12)
    assert math.isclose(tr["joint_forces"]["A"].max(), tr["joint_forces"]["O"].max())

"""Buffered CasADi calls return exactly what ``Function.call`` returns."""
from __future__ import annotations

import threading

import numpy as np
import pytest

from optdesign.numerics.buffered import buffered
from optdesign.evaluation.design import Design
from optdesign.problem.loader import load_problem

ROOT = "problems/"


def _design(name: str) -> Design:
    return Design.from_problem(load_problem(ROOT + name))


def _reference(function, *args) -> np.ndarray:
    return np.concatenate([np.array(v).ravel(order="F") for v in function.call(list(args))])


@pytest.mark.parametrize("name", ["sharkov2022_disc.yaml", "vergov_solve.yaml"])
def test_chain_calls_are_bit_identical(name):
    design = _design(name)
    p = design.p_fixed(0.7)
    for k in range(design.count):
        f = design.model.chain(design.count, design.option_key, k)
        for phi in np.linspace(0.0, 2 * np.pi, 17):
            assert np.array_equal(buffered(f)(phi, p), _reference(f, phi, p))
            assert design.chain_at(phi, k, 0.7) == tuple(_reference(f, phi, p))


def test_structurally_zero_outputs_read_zero():
    """The slotted lever's cos μ does not move with the crank: d cos μ/dφ has no entry."""
    design = _design("vergov_solve.yaml")
    f = design.model.chain(design.count, design.option_key, 0)
    assert f.nnz_out(4) == 0
    assert buffered(f)(0.4, design.p_fixed())[-1] == 0.0


def test_short_grids_and_single_angles_match_casadi():
    design = _design("sharkov2022_disc.yaml")
    phi = np.array([0.1, 1.3, 2.9, 5.0])
    sampled = design.sample(phi, 0.5)
    fmap = design.model.mapped(design.count, design.option_key, phi.size)
    for key, value in zip(("theta", "dtheta", "ddtheta", "cos_mu"),
                          fmap(phi[None, :], design.p(0.5))):
        assert np.array_equal(sampled[key], np.array(value))
    one = design.at(1.3, 0.5)
    for key in one:
        assert np.array_equal(one[key], sampled[key][:, 1])


def test_wrong_argument_count_is_refused():
    design = _design("sharkov2022_disc.yaml")
    f = design.model.chain(design.count, design.option_key, 0)
    with pytest.raises(TypeError):
        buffered(f)(0.3)


def test_every_thread_has_its_own_buffer():
    """A buffer is state: two threads never share one, and each gets its own answers."""
    design = _design("sharkov2022_disc.yaml")
    f = design.model.chain(design.count, design.option_key, 1)
    p = design.p_fixed()
    angles = np.linspace(0.0, 6.0, 400)
    expected = {phi: _reference(f, phi, p) for phi in angles}
    calls, wrong = [], []

    def work(order):
        calls.append(buffered(f))
        for phi in order:
            if not np.array_equal(buffered(f)(phi, p), expected[phi]):
                wrong.append(phi)

    threads = [threading.Thread(target=work, args=(angles,)),
               threading.Thread(target=work, args=(angles[::-1],))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert calls[0] is not calls[1] and buffered(f) not in calls
    assert not wrong

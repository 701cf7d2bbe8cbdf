"""The exact evaluator does each piece of its work once: a run's two ends sampled once, the
curves stacked as their definition says, no search for the least transmission angle where
cos μ does not move with the crank, and its memory of designs let go on request."""
import numpy as np
import pytest

from optdesign.envelope import exact
from optdesign.evaluation import figures as evaluation
from optdesign.evaluation.design import Design
from optdesign.problem.loader import load_problem

DISC = {"l0": 225.0, "l1": 20.0, "l2": 225.0, "l2_prime": 100.0, "l3": 56.0}


def _disc(count: int = 6) -> Design:
    return Design("fourbar_converter", DISC | {"phases": count})


def test_a_runs_two_ends_are_sampled_once(monkeypatch):
    """The envelope's value at a run's ends, the brackets of its stationary points and its
    angle increment read one sample of the two ends (they sampled them three times)."""
    pairs = []
    real = Design.sample

    def counted(self, phi, eccentricity=1.0):
        if np.size(phi) == 2:
            pairs.append(tuple(np.ravel(phi)))
        return real(self, phi, eccentricity)

    monkeypatch.setattr(Design, "sample", counted)
    figures, runs = exact.exact_figures(_disc(6), "forward", 1.0)
    assert len(runs) == 6
    ends = {tuple(np.mod([r.start, r.end], exact.TWO_PI)) for r in runs}
    assert len(pairs) == len(runs) and set(pairs) == ends
    assert figures.delta > 0


@pytest.mark.parametrize("stroke", ["forward", "reverse", "both"])
def test_stacked_curves_are_the_signed_speeds_then_zero(stroke):
    """f = s·dθ/dφ and f' = s·d²θ/dφ² for each sign of the stroke, chains in order, then the
    zero curve: to the bit."""
    design = _disc(4)
    curves = exact.Curves(design, stroke, 1.0)
    out = design.sample(np.linspace(0.0, 6.0, 7))
    f, df = curves.stack(out)
    signs = {"forward": (1,), "reverse": (-1,), "both": (1, -1)}[stroke]
    want_f = np.vstack([s * out["dtheta"] for s in signs] + [np.zeros((1, 7))])
    want_df = np.vstack([s * out["ddtheta"] for s in signs] + [np.zeros((1, 7))])
    assert f.shape == (curves.m, 7)
    assert np.array_equal(f, want_f) and np.array_equal(df, want_df)


def test_no_angle_search_where_cos_mu_does_not_move(monkeypatch):
    """The slotted lever's cos μ is the same at every crank angle: its least transmission
    angle is the grid's, to the bit the value the search found, and no search is made."""
    problem = load_problem("problems/vergov_solve.yaml")
    count = 5
    design = Design.from_problem(problem, problem.start_values() | {"phases": count})
    assert not design.model.has_transmission_angle(count, design.option_key)
    phi = np.linspace(0.0, 2 * np.pi, 64, endpoint=False)
    cos_mu = design.sample(phi)["cos_mu"]
    searched = []
    for k in range(cos_mu.shape[0]):
        j = int(np.argmax(np.abs(cos_mu[k])))
        lo, hi = phi[j - 1] - (2 * np.pi if j == 0 else 0.0), phi[(j + 1) % 64]
        c = design.largest_cos(k, lo, hi + (2 * np.pi if j == 63 else 0.0), xatol=1e-10)[1]
        searched.append(np.degrees(np.arccos(min(max(c, abs(cos_mu[k, j])), 1.0))))

    def no_search(*args, **kwargs):
        raise AssertionError("searched a cos μ that does not move")

    monkeypatch.setattr(Design, "largest_cos", no_search)
    angles = design.transmission_angles(phi=phi, cos_mu=cos_mu)
    assert np.array_equal(angles, np.array(searched))


def test_forget_lets_go_of_every_evaluation():
    """After :func:`forget`, a design evaluated before is evaluated anew (a warm process's
    measure of a new problem), with the same figures; its turn quantities' maxima too."""
    from optdesign.quantities import base as quantities_base, get_quantity

    design = _disc(4)
    first = evaluation.evaluate(design, "forward", 1.0)
    assert evaluation.evaluate(design, "forward", 1.0).per_e[0] is first.per_e[0]
    housing = get_quantity("housing_radius")
    maxima = housing.maxima(design)
    assert housing.maxima(design) is maxima and quantities_base._MAXIMA
    refined = evaluation.refined(design, "forward", 1.0, 1.0, 2)
    assert evaluation.refined(design, "forward", 1.0, 1.0, 2) is refined
    evaluation.forget()
    assert not evaluation._EVALUATED and not evaluation._WORST_CACHE
    assert not evaluation._REFINED and not quantities_base._MAXIMA
    again = evaluation.evaluate(design, "forward", 1.0)
    assert again.per_e[0] is not first.per_e[0]
    assert again.per_e[0].figures == first.per_e[0].figures
    assert housing.maxima(design) is not maxima
    assert np.array_equal(housing.maxima(design).values, maxima.values)


def test_an_evaluation_made_beside_is_remembered_here(monkeypatch):
    """An exact check made in a process forked from this one (a polish beside the solve),
    handed back and remembered, is read by the next check of that design here: nothing is
    evaluated again, and the figures are the child's to the bit (the regulation interval's
    worst too)."""
    from optdesign.lifetime import beside
    from tests.conftest import ROOT

    problem = load_problem(ROOT / "problems" / "sharkov2022_disc_interval.yaml")
    evaluation.forget()
    made = beside(evaluation.evaluate_problem, problem)()
    assert made.worst is not None and not evaluation._EVALUATED
    evaluation.remember(problem, made)

    def not_again(*args, **kwargs):
        raise AssertionError("evaluated again")

    monkeypatch.setattr(evaluation, "_evaluate_at", not_again)
    monkeypatch.setattr(evaluation, "worst_over_range", not_again)
    here = evaluation.evaluate_problem(problem)
    assert [x.figures for x in here.per_e] == [x.figures for x in made.per_e]
    assert here.worst.delta == made.worst.delta

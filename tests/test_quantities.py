"""Quantities (optdesign.quantities): each exact form against a grid of 10⁶ crank angles.

The exact form finds every component's maximum over the turn at a stationary point (Brent's
method on g' from algorithmic differentiation). A grid of 10⁶ equal steps (h = 6.3e-6 rad) is
below a smooth maximum by at most g''·h²/8, about 5e-12 of the value for these designs, so
the two must agree to 1e-9 relative, and the grid may never exceed the exact value by more
than rounding. Piecewise mechanisms add their breakpoints' one-sided limits to the grid, as
the exact form does.
"""
import math

import numpy as np
import pytest

from optdesign.envelope.exact import search_grid
from optdesign.evaluation.design import Design
from optdesign.evaluation.figures import evaluate_problem
from optdesign.problem.loader import load_problem
from optdesign.quantities import design_quantities, get_quantity, known, quantities_of
from optdesign.quantities.extremes import BREAK_STEP, _sample
from tests.conftest import ROOT, near_starter

TURN = ("housing_radius", "peak_acceleration", "swing")
FILES = ("sharkov2022.yaml", "vergov.yaml", "pulse_reducer.yaml")
GRID = 10 ** 6


def _grid_value(quantity, design, e, input_speed):
    g, _ = quantity.function(design.model, design.count, design.option_key)
    phi = np.linspace(0.0, 2 * math.pi, GRID, endpoint=False)
    breaks = [b % (2 * math.pi) for b in design.breakpoints(e)]
    phi = np.union1d(phi, [x % (2 * math.pi) for b in breaks
                           for x in (b - BREAK_STEP, b + BREAK_STEP)])
    grid = _sample(g, phi, design.p(e))
    figures = np.asarray(quantity.components(grid.max(axis=1), input_speed))
    return quantity.worst_of(figures)


@pytest.mark.parametrize("name", TURN)
@pytest.mark.parametrize("file", FILES)
def test_the_exact_form_agrees_with_a_million_samples(file, name):
    problem = load_problem(ROOT / "problems" / file)
    ev = evaluate_problem(problem)
    quantity = get_quantity(name)
    for e in problem.eccentricities:
        exact = quantity.exact(ev, e)
        sampled = _grid_value(quantity, ev.design, e, problem.input_speed)
        scale = max(abs(exact), 1e-300)
        assert abs(exact - sampled) <= 1e-9 * scale, (file, name, e, exact, sampled)
        # a maximum is never below what a sample shows (a least swing: its members' maxima)
        assert exact >= sampled - 1e-12 * scale


def test_closed_forms_of_the_paper_design():
    """Checks a reader can do by hand: the crank pin A turns on a circle of radius l1·e, the
    peak acceleration is ω1²·max|d²θ/dφ²| and the swing shrinks with the eccentricity."""
    problem = load_problem(ROOT / "problems" / "sharkov2022.yaml")
    ev = evaluate_problem(problem)
    q = quantities_of(ev, problem.eccentricities, problem.objective.ripple)
    design = ev.design
    phi = np.linspace(0, 2 * math.pi, 4096, endpoint=False)
    sampled = design.sample(phi)
    accel = problem.input_speed ** 2 * np.abs(sampled["ddtheta"]).max()
    assert q["values"]["peak_acceleration"] == pytest.approx(accel, rel=1e-4)
    joints, names, _ = design.model.joints(design.count, design.option_key)
    a = np.array(joints(0.3, design.p()))[:, names.index("A")]
    assert math.hypot(*a) == pytest.approx(design.values["l1"], rel=1e-12)
    assert q["values"]["housing_radius"] >= design.values["l1"]
    rows = q["per_eccentricity"]
    swings = [r["swing"] for r in rows]
    assert swings == sorted(swings, reverse=True)         # e = 1, 0.5, 0.25
    assert q["values"]["swing"] == min(swings)
    assert q["values"]["ratio"] == ev.ratio               # at e = 1
    assert q["values"]["ripple"] == ev.ripple(problem.objective.ripple,
                                              problem.eccentricities)


def test_every_quantity_has_a_unit_a_label_and_a_side():
    assert set(TURN) | {"ratio", "ripple", "peak_speed", "transmission_angle"} <= set(known())
    for name in known():
        q = get_quantity(name)
        assert q.name == name and q.unit and q.label and q.meaning
        assert q.worst in ("max", "min")
    with pytest.raises(KeyError, match="known: housing_radius"):
        get_quantity("casing")


def test_a_design_that_does_not_assemble_has_no_quantities():
    problem = load_problem(ROOT / "problems" / "sharkov2022.yaml")
    ev = evaluate_problem(problem, {"l3": 5.0})
    assert not ev.assembles
    assert design_quantities(problem, ev) == {}


@pytest.mark.parametrize("mechanism", ["fourbar_converter", "slotted_lever", "pulse_reducer"])
def test_quantities_share_one_model_and_keep_their_own_arithmetic(mechanism):
    """Every turn quantity's g and dg/dφ are built on one symbolic model per count (built
    once): the same figures, to the bit, as on a model built for the quantity alone."""
    import casadi as ca

    from optdesign.mechanisms import get_mechanism
    from optdesign.quantities.base import TurnQuantity

    model = get_mechanism(mechanism)
    options = tuple(sorted(model.default_options().items()))
    rng = np.random.default_rng(11)
    turn = [get_quantity(n) for n in known() if isinstance(get_quantity(n), TurnQuantity)]
    assert turn
    for quantity in turn:
        phi, pvec = ca.SX.sym("phi"), ca.SX.sym("p", len(model.lengths))
        p = {name: pvec[i] for i, name in enumerate(model.lengths)}
        alone = dict(model.chain_expressions(phi, p, 5, model.default_options()))
        alone["dtheta"] = ca.jacobian(ca.vertcat(*alone["theta"]), phi)
        alone["ddtheta"] = ca.jacobian(alone["dtheta"], phi)
        g = ca.vertcat(*quantity.expression(alone, phi, p, 5))
        reference = ca.Function("alone", [phi, pvec], [g, ca.jacobian(g, phi)])
        shared = quantity.function(model, 5, options)
        for _ in range(3):
            angles = ca.DM(rng.uniform(0.0, 2 * np.pi, 7)).T
            lengths = ca.DM(near_starter(model, rng, 0.02))
            want = [np.array(v) for v in reference(angles, lengths)]
            got = [np.array(f(angles, lengths)) for f in shared]
            assert all(np.array_equal(a, b, equal_nan=True) for a, b in zip(got, want))


def test_the_grid_peaks_of_every_row_at_once_are_each_row_s_own():
    """turn_maxima finds the peaks of every component in one pass over the grid: the same
    samples as the former loop over the rows, each row rolled alone (plateaus, a row's
    wrap-around, NaN and inf among them)."""
    from optdesign.quantities.extremes import grid_peaks

    rng = np.random.default_rng(3)
    grid = np.round(rng.normal(size=(9, 64)), 1)          # rounded: plateaus and ties
    grid[2, 5] = np.nan
    grid[3, 7] = np.inf
    grid[4] = np.sin(np.linspace(0.0, 2 * np.pi, 64, endpoint=False) + 0.05)  # a peak at 0
    grid[5] = 1.0                                          # constant

    def row_alone(row):
        left, right = np.roll(row, 1), np.roll(row, -1)
        curvature = np.abs(left - 2 * row + right)
        with np.errstate(invalid="ignore"):
            return (row >= left) & (row >= right) & ((row > left) | (row > right)) & \
                (row + 4 * curvature >= row.max()) & np.isfinite(row)

    expected = np.array([row_alone(row) for row in grid])
    assert np.array_equal(grid_peaks(grid), expected)
    assert expected.sum() > 9 and expected[4].any() and not expected[5].any()


@pytest.mark.parametrize("name", ["housing_radius", "peak_acceleration", "swing"])
def test_a_function_searched_again_is_searched_by_component_to_the_bit(name, monkeypatch):
    """A turn quantity's function searched a second time in the process searches each
    component on a function of its own (a fraction of the instructions): the same maxima
    and angles to the bit as the whole function gives, on designs of the disc problem at 24
    phases."""
    from optdesign.quantities import extremes

    problem = load_problem(ROOT / "problems" / "sharkov2022_disc.yaml")
    quantity = get_quantity(name)
    rng = np.random.default_rng(2)
    designs = []
    for _ in range(3):
        values = problem.start_values() | {"phases": 24}
        values |= {k: values[k] * float(rng.uniform(0.97, 1.03)) for k in problem.free_lengths()}
        designs.append(Design.from_problem(problem, values))
    g, dg = quantity.function(designs[0].model, 24, designs[0].option_key)
    monkeypatch.setattr(extremes, "_SEARCHED", {})
    searches = []
    for design in designs:      # the first search whole, the others by component
        p, phi = design.p_fixed(1.0), search_grid(design, 1.0)
        searches.append((extremes.turn_maxima(g, dg, p, phi), p, phi))
    made = extremes._SEARCHED[id(dg)][3]
    assert made and all(f.n_instructions() < dg.n_instructions() / 4 for f in made.values())
    monkeypatch.setattr(extremes, "_searched_before", lambda function: False)
    for found, p, phi in searches:          # the whole function, each again
        whole = extremes.turn_maxima(g, dg, p, phi)
        assert found.values.tobytes() == whole.values.tobytes()
        assert found.angles.tobytes() == whole.angles.tobytes()

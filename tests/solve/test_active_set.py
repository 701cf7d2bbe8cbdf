"""The active set a solve reports: what binds, and d δ / d bound from IPOPT's multipliers,
checked against re-solves with the bound moved (finite differences of verified optima)."""
from dataclasses import replace

import pytest

from optdesign.problem.loader import load_problem
from optdesign.quantities.bounds import ALIASES
from optdesign.solver.driver import solve_phase
from tests.conftest import ROOT


@pytest.fixture(scope="module")
def disc():
    problem = load_problem(ROOT / "problems" / "sharkov2022_disc.yaml")
    return problem, solve_phase(problem, 6, workers=1)


#: the older keys, each a side of a bound on a quantity
OLDER = {key: side for side, (_, key) in ALIASES.items()}


def _delta(problem, **changes):
    own = {k: v for k, v in changes.items() if k in problem.constraints.own}
    c = replace(problem.constraints, own={**problem.constraints.own, **own})
    for key, value in changes.items():
        if key not in own:
            c = c.with_limit(*OLDER[key], value)
    return solve_phase(replace(problem, constraints=c), 6, workers=1).delta


def test_the_disc_optimum_names_what_binds(disc):
    problem, result = disc
    names = {a["name"] for a in result.active}
    assert {"transmission_angle[e1]", "pin_radius", "l2 upper bound"} <= names
    angle = next(a for a in result.active if a["name"] == "transmission_angle[e1]")
    assert angle["unit"] == "deg" and angle["kind"] == "constraint"


@pytest.mark.parametrize("name, key, step", [
    ("transmission_angle[e1]", "min_transmission_angle_deg", 0.05),
    ("pin_radius", "min_pin_radius", 0.5),
])
def test_sensitivities_match_re_solves(disc, name, key, step):
    problem, result = disc
    reported = next(a["sensitivity"] for a in result.active if a["name"] == name)
    base = getattr(problem.constraints, key)
    up, down = _delta(problem, **{key: base + step}), _delta(problem, **{key: base - step})
    measured = (up - down) / (2 * step)
    assert reported == pytest.approx(measured, rel=0.02)


def test_a_length_bound_sensitivity_matches_a_re_solve(disc):
    """Tightened, not widened: l0 sits 0.02 mm below its own upper bound, so one more mm of
    l2 moves l0 onto that bound and the slope changes there (a one-sided derivative)."""
    problem, result = disc
    reported = next(a["sensitivity"] for a in result.active if a["name"] == "l2 upper bound")
    step = -1.0
    wider = replace(problem, design=problem.design | {
        "l2": replace(problem.design["l2"], upper=problem.design["l2"].upper + step)})
    measured = (solve_phase(wider, 6, workers=1).delta - result.delta) / step
    assert reported == pytest.approx(measured, rel=0.05)


def test_a_pin_radius_held_at_zero_and_a_length_on_its_bound_are_warned_of(disc):
    """Without min_pin_radius the optimum puts every rod on the crank pin (l2 = l2'):
    the summary says so, and names the lengths resting on a bound."""
    from optdesign.solver.driver import solve
    from optdesign.solver.outputs import summary_text

    problem, _ = disc
    own = {**problem.constraints.own, "min_pin_radius": 0.0}
    loose = replace(problem, constraints=replace(problem.constraints, own=own),
                    design=problem.design | {"l2": replace(problem.design["l2"], upper=300.0)})
    text = summary_text(solve(loose), loose)
    assert "warning: pin_radius is held at 0 mm" in text
    assert "warning: l2 rests on its upper bound, 300 mm" in text

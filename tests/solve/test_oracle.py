"""The solver's verdicts against a brute-force oracle (``benchmarks/oracle.py``): random
problems drawn through hypothesis (a mechanism, a box of one to six decades with or without
initial values, a count, a stroke, random bounds on random quantities on either side or both,
an objective minimised or maximised), each verdict judged against a sample of its box checked
by the exact evaluator. Never ``infeasible`` or ``failed`` where a checked design meets every
constraint; never an ``optimal`` that one beats or that the exact check rejects.

A small draw runs here (derandomised: the same problems on every run; boxes of one to two
decades, the wider ones being slow to solve); ``python benchmarks/solve_oracle.py``
runs several hundred with boxes of up to six decades.
"""

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from benchmarks import oracle



@st.composite
def draws(draw):
    mechanism = draw(st.sampled_from(sorted(oracle.BASES)))
    names = oracle.QUANTITIES[mechanism]
    bounds = draw(st.lists(st.tuples(st.integers(0, len(names) - 1),
                                     st.sampled_from(["lower", "upper", "both"]),
                                     st.floats(-0.1, 1.1)), max_size=2))
    objective = (draw(st.sampled_from(("ripple",) + names)), draw(st.booleans()))
    return oracle.Draw(mechanism, draw(st.floats(1.0, 2.0)), draw(st.floats(0.0, 0.99)),
                       draw(st.booleans()), draw(st.integers(0, 3)), draw(st.integers(0, 2)),
                       tuple(bounds), objective, draw(st.integers(0, 10 ** 6)))


@pytest.mark.filterwarnings("ignore::UserWarning")
@settings(max_examples=4, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(draws())
def test_no_verdict_contradicts_a_checked_sample_of_the_box(draw):
    row = oracle.run(draw)
    assert row["false"] == 0, row["claims"]

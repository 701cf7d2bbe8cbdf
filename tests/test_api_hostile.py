"""The Python API is a front door as the command line is: every public function checks its
arguments by the loader's rules and answers a hostile value with a clear exception of one line
(``ProblemError``, a ``ValueError``, or ``TypeError``) or a verified result, never an error from
deep inside (ZeroDivisionError, IndexError, KeyError, a NumPy or CasADi error), never a silent
wrong answer, never a hang (the counts are bounded as in a file)."""
import math

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from optdesign import api
from optdesign.errors import OptDesignError, ProblemError
from tests.conftest import ROOT

PAPER = api.load_problem(ROOT / "problems" / "sharkov2022.yaml")
FRONT = ROOT / "problems" / "pareto_fourbar.yaml"

#: the values a careless or hostile caller may pass where a number belongs
HOSTILE = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**6, 10**6),
    st.booleans(), st.none(), st.text(max_size=5), st.lists(st.integers(), max_size=3),
    st.sampled_from([0, -1, 1e-300, 1e300, 2.5, 100000, -20.0]))
KEYS = st.sampled_from(["l0", "l1", "l2", "l2_prime", "l3", "phases", "l9", "", "phases "])
DESIGNS = st.dictionaries(KEYS, HOSTILE, max_size=3)
FAST = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def _clean(call):
    """Run ``call``: its result, or the clear exception it raised (one line)."""
    try:
        return call()
    except (OptDesignError, TypeError, ValueError) as exc:
        # ours (ProblemError, UsageError) or our own TypeError of a wrong kind of argument;
        # a bare ValueError would come from NumPy or CasADi, deep inside
        assert isinstance(exc, (OptDesignError, TypeError)), repr(exc)
        assert "\n" not in str(exc).strip(), repr(exc)
        return exc


@FAST
@given(design=DESIGNS)
def test_analyze_takes_a_design_only_by_the_loaders_rules(design):
    out = _clean(lambda: api.analyze(PAPER, design))
    if isinstance(out, Exception):
        return
    # what was analysed is what was given: no key dropped, no count rounded, no NaN
    for key, value in design.items():
        assert out.design[key] == value
        assert not isinstance(value, bool) and math.isfinite(value) and value > 0
    if "phases" in design:
        assert float(design["phases"]).is_integer()


@FAST
@given(design=DESIGNS, e=HOSTILE)
def test_the_plots_check_the_design_and_the_eccentricity(design, e):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = _clean(lambda: api.plot_speeds(PAPER, design, eccentricity=e))
    if not isinstance(out, Exception):
        assert 0 < e <= 1
        plt.close(out)


@FAST
@given(angles=st.one_of(st.lists(HOSTILE, max_size=14), HOSTILE))
def test_plot_mechanism_checks_its_angles(angles):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = _clean(lambda: api.plot_mechanism(PAPER, angles_deg=angles))
    if not isinstance(out, Exception):
        assert 1 <= len(angles) <= 12
        plt.close(out)


@FAST
@given(e=st.one_of(HOSTILE, st.lists(HOSTILE, max_size=3),
                   st.dictionaries(st.sampled_from(["lower", "upper", "x"]), HOSTILE)))
def test_variants_are_validated(e):
    out = _clean(lambda: PAPER.with_eccentricities(e))
    if not isinstance(out, Exception):
        assert all(0 < x <= 1 for x in out.eccentricities)


@FAST
@given(lower=HOSTILE, upper=HOSTILE)
def test_bounds_are_validated(lower, upper):
    out = _clean(lambda: PAPER.with_bounds(l3=(lower, upper)))
    if not isinstance(out, Exception):
        assert 0 < lower <= upper
        l3 = out.design["l3"]
        assert (l3.lower, l3.upper) == (lower, upper) if lower < upper else l3.value == lower


@settings(max_examples=25, deadline=None)
@given(points=HOSTILE, workers=HOSTILE, resume=HOSTILE)
def test_pareto_checks_its_arguments_before_any_work(points, workers, resume):
    from unittest import mock

    ran = []
    with mock.patch("optdesign.fronts.sweep.sweep",
                    lambda *a, **k: ran.append(k) or "ran"):
        out = _clean(lambda: api.pareto(FRONT, points=points, workers=workers,
                                        resume=resume))
    if not isinstance(out, Exception):
        kw = ran[0]
        assert kw["points"] is None or 2 <= kw["points"] <= 1000
        assert kw["workers"] is None or 1 <= kw["workers"] <= 256
        assert resume is False


@FAST
@given(design=DESIGNS)
def test_sensitivities_take_a_design_by_the_same_rules(design):
    out = _clean(lambda: api.sensitivities(PAPER, design))
    if not isinstance(out, Exception):
        assert all(not isinstance(v, bool) and math.isfinite(v) and v > 0
                   for v in design.values())


@settings(max_examples=30, deadline=None)
@given(source=st.one_of(HOSTILE, st.dictionaries(st.text(max_size=4), HOSTILE, max_size=3)))
def test_load_problem_solve_and_plot_front_refuse_what_they_cannot_take(source):
    _clean(lambda: api.load_problem(source))
    assert isinstance(_clean(lambda: api.solve(PAPER, progress=source)), Exception) or \
        callable(source) or source is None
    assert isinstance(_clean(lambda: api.plot_front(source)), Exception)


def test_the_45_kinds_of_call_of_the_audit():
    """The calls the audit found wrong, each now a clear error naming the argument."""
    cases = [
        (lambda: api.analyze(PAPER, {"l9": 3}), "design.l9 is not a known key"),
        (lambda: api.analyze(PAPER, {"l0": float("nan")}), "design.l0 must be finite"),
        (lambda: api.analyze(PAPER, {"l3": 0}), "design.l3 must be positive"),
        (lambda: api.analyze(PAPER, {"phases": 2.5}), "design.phases must be a whole number"),
        (lambda: api.analyze(PAPER, {"phases": True}), "design.phases must be an integer"),
        (lambda: api.analyze(PAPER, {"phases": 0}), "design.phases must be at least 2"),
        (lambda: api.analyze(PAPER, {"phases": 100000}), "design.phases must be at most 64"),
        (lambda: api.analyze(PAPER, {"phases": 7}),
         "design.phases must be a count the problem admits"),
        (lambda: api.analyze(PAPER, {"l3": "x"}), "design.l3 must be a number"),
        (lambda: PAPER.with_eccentricities([-1]), "regulation.eccentricity must be positive"),
        (lambda: PAPER.with_eccentricities([2]), "fractions must lie in"),
        (lambda: api.plot_speeds(PAPER, eccentricity=5), "fractions must lie in"),
        (lambda: api.plot_mechanism(PAPER, {"l1": -20}), "design.l1 must be positive"),
        (lambda: api.plot_mechanism(PAPER, angles_deg=[]), "angles_deg must be a list"),
        (lambda: api.pareto(FRONT, points=0), "points must be at least 2"),
        (lambda: api.pareto(FRONT, resume=True), "resume=True needs out"),
        (lambda: PAPER.with_bounds(l3=(90, 30)), "design.l3.upper must not be below lower"),
    ]
    for call, message in cases:
        with pytest.raises(ProblemError, match=message.replace(".", r"\.")):
            call()


def test_arguments_that_reached_deep_inside_are_refused_at_the_door(tmp_path):
    """A wrong kind of scheduler or axes, and an out that cannot be a folder, each a one-line
    error naming the argument, never an AttributeError or FileExistsError from inside."""
    from optdesign.errors import UsageError

    a_file = tmp_path / "a_file"
    a_file.write_text("mine")
    cases = [
        (lambda: api.pareto(FRONT, scheduler=123), TypeError,
         "scheduler must be an address such as 'tcp://HOST:8786' or a distributed.Client "
         "(got int)"),
        (lambda: api.pareto(FRONT, out="/dev/null"), UsageError,
         "out '/dev/null': is under /dev, not a place for results"),
        (lambda: api.pareto(FRONT, out=a_file), UsageError, "': exists and is not a folder"),
        (lambda: api.pareto(FRONT, progress="yes"), TypeError,
         "progress must be true or false (got str)"),
        (lambda: api.plot_speeds(PAPER, ax="left"), TypeError,
         "ax must be a matplotlib Axes or None (got str)"),
    ]
    for call, kind, message in cases:
        with pytest.raises(kind) as info:
            call()
        assert message in str(info.value) and "\n" not in str(info.value)
    assert a_file.read_text() == "mine"

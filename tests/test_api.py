"""The public Python API (docs/api.md): what a notebook imports, and what it gets back."""
import matplotlib
import pytest

from optdesign.errors import ProblemError
from tests.conftest import ROOT

DISC = ROOT / "problems" / "sharkov2022_disc.yaml"
LEVER = ROOT / "problems" / "vergov_solve.yaml"


def test_the_four_functions_import_from_the_package():
    from optdesign import analyze, load_problem, pareto, solve
    import optdesign.solver.driver as driver           # the packages' modules stay reachable

    assert callable(solve) and callable(pareto) and callable(analyze)
    assert driver.solve_phase is not None
    import inspect

    import optdesign
    import optdesign.api as api
    import optdesign.fronts.sweep  # noqa: F401  (an engine's module imported does not shadow the API)
    assert optdesign.solve is api.solve and optdesign.pareto is api.pareto
    assert list(inspect.signature(solve).parameters)[0] == "problem"
    assert inspect.isfunction(solve) and inspect.isfunction(pareto)
    assert load_problem(DISC).name == "sharkov2022_disc"


def test_a_problem_is_a_path_a_mapping_or_a_problem():
    from optdesign import load_problem

    problem = load_problem(str(DISC))
    assert load_problem(problem) is problem
    as_dict = load_problem({"mechanism": "slotted_lever", "input_speed": 0.628,
                            "design": {"XD": 292, "L": 74, "sections": 5}})
    assert as_dict.mechanism == "slotted_lever"
    with pytest.raises(ProblemError, match="design.XD"):
        load_problem({"mechanism": "slotted_lever", "input_speed": 1.0,
                      "design": {"XD": [1, 2], "L": 74, "sections": 5}})
    with pytest.raises(TypeError):
        load_problem(42)


def test_solve_returns_a_result_that_shows_itself():
    from optdesign import solve

    result = solve(LEVER)
    assert result.status == "optimal"
    frame = result.to_frame()
    assert list(frame["count"]) == list(frame["sections"]) == [3, 5]   # the lever's count
    assert {"delta", "ratio", "XD", "L", "best"} <= set(frame.columns)
    # the lengths named as in every table (pareto.csv, compare.csv, the JSON's design); the
    # older columns one release more, deprecated
    assert list(frame["XD"]) == list(frame["XD_mm"]) and frame.attrs["units"]["XD"] == "mm"
    assert frame.attrs["deprecated"]["L_mm"] == "L"
    assert frame["best"].sum() == 1
    html = result._repr_html_()
    assert f"{result.delta:.6g}" in html and "<table" in html
    assert result.to_dict()["delta"] == result.delta


def test_analyze_checks_the_problem_files_constraints():
    from optdesign import analyze, load_problem

    problem = load_problem(DISC)
    ok = {c["name"]: c for c in analyze(problem).constraints}
    assert ok["transmission_angle"]["satisfied"] and ok["transmission_angle"]["unit"] == "deg"
    assert ok["pin_radius"]["unit"] == "mm"
    # a rocker of 30 mm on the paper's disc: the transmission angle falls to 31°
    bad = analyze(problem, {"l3": 30.0})
    angle = next(c for c in bad.constraints if c["name"] == "transmission_angle")
    assert not angle["satisfied"] and angle["margin"] < 0
    assert "VIOLATED" in __import__("optdesign.analyses.analyze", fromlist=["x"]).format_analysis(bad)
    rows = bad.to_frame()
    assert set(rows["stroke"]) == {"forward", "reverse"} and "delta" in rows


def test_plots_never_switch_the_backend():
    from optdesign import load_problem, plot_speeds

    before = matplotlib.get_backend()
    fig = plot_speeds(load_problem(DISC))
    assert matplotlib.get_backend() == before
    assert fig.axes

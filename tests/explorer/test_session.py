"""The explorer's state without a page: bounds moved by the loader's rules, the exact
figures of each design, a warm re-optimisation that lands on the solver's optimum, and a
saved design.yaml that ``analyze --design`` reads back."""
import json
import math

import pytest

from optdesign.errors import ProblemError, UsageError
from optdesign.explorer.bounds import bounds_of
from optdesign.explorer.session import Session
from tests.conftest import ROOT, file_data, run_main

DISC = ROOT / "problems" / "sharkov2022_disc.yaml"


@pytest.fixture
def session():
    return Session.open(DISC)


def test_every_constraint_bound_is_a_slider_named_by_its_file_key(session):
    bounds = {b.key: b for b in bounds_of(session.problem)}
    assert list(bounds) == ["constraints.min_transmission_angle_deg", "objective.min_ratio",
                            "constraints.min_pin_radius"]
    assert (bounds["constraints.min_pin_radius"].value, bounds["objective.min_ratio"].value) \
        == (125.0, 0.344)
    assert all(b.lower <= b.value <= b.upper and b.step > 0 for b in bounds.values())


def test_a_bound_is_moved_by_the_loaders_rules(session):
    session.set_bound("constraints.min_pin_radius", 130)
    assert session.problem.constraints.own["min_pin_radius"] == 130
    assert session.data["constraints"]["min_pin_radius"] == 130
    with pytest.raises(ProblemError, match=r"sharkov2022_disc.yaml: "
                       r"constraints.min_transmission_angle_deg must lie in \[0, 90\) deg "
                       r"\(got 95\)"):
        session.set_bound("constraints.min_transmission_angle_deg", 95)
    assert session.problem.constraints.min_transmission_angle_deg == 40   # unchanged


def test_a_length_outside_the_files_range_is_refused(session):
    with pytest.raises(UsageError, match=r"design.l3 = 500 lies outside the file's range "
                                         r"\[20, 150\]"):
        session.set("l3", 500)
    with pytest.raises(ProblemError, match=r"sharkov2022_disc.yaml: design.l3 must be positive \(got -1\)"):
        session.set("l3", -1)


def test_each_move_is_the_exact_evaluators_figures(session):
    from optdesign import analyze

    session.set("l3", 57)
    shot = session.evaluate()
    exact = analyze(DISC, session.values)
    assert shot.delta_text == exact.ripples().worst.text(6) == \
        "δ (midrange, worst over e = 1) = " + f"{exact.ripples().worst.value:.6f}"
    assert shot.ratio == exact.quantities["values"]["ratio"]
    # the page evaluates the problem's stroke alone: every figure it shows is analyze's
    assert shot.analysis.quantities == exact.quantities
    assert shot.analysis.constraints == exact.constraints
    assert shot.analysis.min_transmission_angle_deg == exact.min_transmission_angle_deg
    assert shot.analysis.strokes["forward"] == exact.strokes["forward"]
    assert list(shot.analysis.strokes) == ["forward"] and "reverse" in exact.strokes
    names = [r.name for r in shot.rows()]
    assert "margin of pin_radius" in names and "housing_radius" in names
    # the drawing at crank angle 0 is the mechanism's joints there
    from optdesign.evaluation.design import Design
    from optdesign.figures.design import linkage

    at = linkage(Design.from_problem(session.problem, session.values)).at(0.0)
    t = shot.turn
    assert t.phi_deg[0] == 0
    for j, name in enumerate(t.names):
        assert t.positions[0, j] == pytest.approx(at[name], abs=1e-9)


def test_a_design_that_does_not_assemble_says_where(session):
    session.set("l3", 20)
    shot = session.evaluate()
    assert not shot.assembles and shot.turn is None
    assert "does not assemble at crank angle 0.00 deg" in shot.message
    assert shot.rows() == []
    session.set("l3", 56)                     # and the session goes on
    assert session.evaluate().assembles


def test_a_violated_constraint_is_marked(session):
    session.set("l2_prime", 110)              # pin radius 115 < 125
    rows = {r.name: r for r in session.evaluate().rows()}
    assert rows["margin of pin_radius"].violated
    assert rows["margin of pin_radius"].value.startswith("-10 mm")


def test_follow_lands_on_the_solvers_optimum_for_the_new_bound(session, tmp_path):
    """A bound moved from the optimum: one warm polish on the NLP already built ends where
    a cold solve of the file with that bound ends (the same design to 1e-6 relative, δ to
    1e-9)."""
    from optdesign import solve

    session.prepare()
    first = session.reoptimise()
    assert first.status == "optimal"
    nlps = dict(session.reoptimiser._solvers)
    session.set_bound("constraints.min_pin_radius", 130)
    moved = session.reoptimise()
    assert moved.status == "optimal" and "pin_radius" in moved.binding
    assert session.reoptimiser._solvers == nlps          # the same NLP, not a new one
    cold = solve(file_data(DISC, constraints={"min_transmission_angle_deg": 40,
                                              "min_pin_radius": 130}))
    assert moved.delta == pytest.approx(cold.delta, rel=1e-9)
    for k, v in cold.design.items():
        assert session.values[k] == pytest.approx(v, rel=1e-6), k
    assert session.values["l2"] - session.values["l2_prime"] == pytest.approx(130, abs=1e-6)


def test_save_writes_a_design_analyze_reads_back(session, tmp_path):
    session.set("l3", 55.5)
    session.set_bound("constraints.min_pin_radius", 120)
    path = session.save(tmp_path / "saved" / "design.yaml")
    assert not list(path.parent.glob(".*.tmp"))               # written atomically
    code, out = run_main(["analyze", DISC, "--design", path, "--json"])
    assert code == 0
    doc = json.loads(out)
    assert doc["delta_named"]["worst"]["label"] + f" = {doc['delta_named']['worst']['delta']:.6f}" \
        == session.evaluate().delta_text
    assert doc["design"]["l3"] == 55.5
    code, out = run_main(["analyze", path, "--json"])          # runnable as it is
    assert code == 0 and json.loads(out)["design"]["l3"] == 55.5
    assert "min_pin_radius: 120" in path.read_text()


def test_a_design_file_opens_the_session(tmp_path):
    from tests.conftest import run_main as run

    out = tmp_path / "solved"
    code, _ = run(["solve", DISC, "--out", out, "--no-plots"])
    assert code == 0
    for name in ("result.json", "design.yaml"):
        s = Session.open(DISC, out / name)
        assert math.isclose(s.values["l0"], json.loads((out / "result.json").read_text())
                            ["design"]["l0"])
    with pytest.raises(UsageError, match="has no design object"):
        (tmp_path / "x.json").write_text("{}")
        Session.open(DISC, tmp_path / "x.json")


def test_a_problem_object_opens_without_its_file(tmp_path, monkeypatch):
    """A Problem keeps only its file's name: from a folder where that name is no file, the
    mapping is written anew from the Problem and reads back to it; bounds move, the figures
    are analyze's, and a saved design runs as it is."""
    from optdesign import analyze, explore, load_problem

    problem = load_problem(DISC)
    monkeypatch.chdir(tmp_path)                 # the file's name is no file here
    session = Session.open(problem)
    assert session.problem == problem
    session.set("l3", 55.5)
    assert session.evaluate().delta_text == analyze(problem, session.values).ripples() \
        .worst.text(6)
    assert "constraints.min_pin_radius" in [b.key for b in session.bounds()]
    session.set_bound("constraints.min_pin_radius", 120)
    assert session.problem.constraints.own["min_pin_radius"] == 120
    path = session.save(tmp_path / "design.yaml")
    code, out = run_main(["analyze", path, "--json"])           # runnable as it is
    assert code == 0 and json.loads(out)["design"]["l3"] == 55.5
    assert explore(problem) is not None         # the notebook's widget, from the Problem


def test_a_problem_changed_in_code_is_explored_as_changed():
    """The file is found, but the Problem was changed since: the explorer shows the Problem,
    not the file."""
    from optdesign import load_problem

    problem = load_problem(DISC).with_bounds(l3=(30, 90))
    session = Session.open(problem)
    assert ("l3", 30, 90) in session.lengths() and session.problem == problem


def test_a_problem_with_a_section_needs_its_file(tmp_path, monkeypatch):
    from optdesign import load_problem

    problem = load_problem(ROOT / "problems" / "sharkov2022_disc_tolerance.yaml")
    monkeypatch.chdir(ROOT / "problems")        # its name is its file here: read
    assert Session.open(problem).problem == problem
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ProblemError, match=r"sharkov2022_disc_tolerance.yaml: the explorer "
                       r"moves bounds in the problem file's keys, and this Problem's file is "
                       r"not found from here \(its tolerances: cannot be written anew\)"):
        Session.open(problem)

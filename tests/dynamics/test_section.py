"""The dynamics: section: every message a user can meet, and what the section must not do."""
import pytest
import yaml

from optdesign.cli import main
from optdesign.errors import ProblemError
from optdesign.problem.loader import load_problem
from tests.conftest import ROOT, base_problem

DYN = dict(I1=0.014, I2=0.05, stiffness=2877.0, motor={"a": 230.0, "b": 2.35}, load=5.0)


def problem_with(write_problem, **changes):
    dyn = dict(DYN)
    for key, value in changes.items():
        if value is None:
            dyn.pop(key)
        else:
            dyn[key] = value
    return write_problem(base_problem(dynamics=dyn))


@pytest.mark.parametrize("changes, message", [
    (dict(I1=None), "p.yaml: dynamics.I1 is required"),
    (dict(I2=-1.0), r"p.yaml: dynamics.I2 must be positive \(got -1\)"),
    (dict(I1="heavy"), r"p.yaml: dynamics.I1 must be a number \(got 'heavy'\)"),
    (dict(stiffness=[]), r"p.yaml: dynamics.stiffness must be a number or a non-empty list"),
    (dict(stiffness=0.0), r"p.yaml: dynamics.stiffness must be positive \(got 0\)"),
    (dict(motor=None), "p.yaml: dynamics.motor is required"),
    (dict(motor={"a": 230.0}), r"p.yaml: dynamics.motor.b is required \(motor torque"),
    (dict(motor={"a": 230.0, "b": 2.35, "c": 1.0}), "p.yaml: dynamics.motor.c is not a known key"),
    (dict(motor=230.0), r"p.yaml: dynamics.motor must be a mapping \(got float\)"),
    (dict(load=-2.0), r"p.yaml: dynamics.load must not be negative \(got -2\)"),
    (dict(load={"angle_deg": [0, 180], "torque": [1.0]}),
     "p.yaml: dynamics.load.torque must be a list of at least two numbers"),
    (dict(load={"angle_deg": [0, 90, 180], "torque": [1.0, 2.0]}),
     r"p.yaml: dynamics.load.torque must have one value per angle \(got 2 for 3\)"),
    (dict(load={"angle_deg": [0, 180, 90], "torque": [1.0, 2.0, 3.0]}),
     r"p.yaml: dynamics.load.angle_deg must increase strictly within \[0, 360\]"),
    (dict(load={"angle_deg": [0, 180], "torque": [1.0, -2.0]}),
     "p.yaml: dynamics.load.torque must not be negative"),
    (dict(load={"angle": [0, 180]}), "p.yaml: dynamics.load.angle is not a known key"),
    (dict(cycles=0), r"p.yaml: dynamics.cycles must be at least 1 \(got 0\)"),
    (dict(method="Euler"), r"p.yaml: dynamics.method must be one of Radau, BDF, LSODA, RK45"),
    (dict(freewheel="sprag"), r"p.yaml: dynamics.freewheel must be one of ratchet, composite"),
    (dict(crank="rigid"), r"p.yaml: dynamics.crank must be one of dynamic, constant"),
    (dict(damping_ratio=2.0), r"p.yaml: dynamics.damping_ratio must lie in \[0, 1\] \(got 2\)"),
    (dict(rtol=0.1), r"p.yaml: dynamics.rtol must be below 0.01 \(got 0.1\)"),
    (dict(steady_tol=-1e-6), r"p.yaml: dynamics.steady_tol must be positive"),
    (dict(lambda_=1.0), "p.yaml: dynamics.lambda_ is not a known key; known: I1, I2, atol"),
    # the ranges of docs/dynamics.md: far outside any drive, far inside the float range
    (dict(I1=1e-50), r"p.yaml: dynamics.I1 must lie in \[1e-08, 1e\+06\] kg·m² \(got 1e-50\)"),
    (dict(I2=1e7), r"p.yaml: dynamics.I2 must lie in \[1e-08, 1e\+06\] kg·m² \(got 1e\+07\)"),
    (dict(stiffness=1e12),
     r"p.yaml: dynamics.stiffness must lie in \[0.01, 1e\+10\] N·m/rad \(got 1e\+12\)"),
    (dict(stiffness=[2877.0, 1e-3, 1.0, 1.0, 1.0, 1.0]),
     r"p.yaml: dynamics.stiffness must lie in \[0.01, 1e\+10\] N·m/rad \(got 0.001\)"),
    (dict(motor={"a": 1e10, "b": 2.35}), r"p.yaml: dynamics.motor.a must lie in \[1e-06, 1e\+09\]"),
    (dict(motor={"a": 230.0, "b": 1e-12}),
     r"p.yaml: dynamics.motor.b must lie in \[1e-09, 1e\+09\] N·m·s \(got 1e-12\)"),
    (dict(load=1e-20), r"p.yaml: dynamics.load must lie in \[1e-09, 1e\+09\] N·m or be 0"),
    (dict(load={"angle_deg": [0, 180], "torque": [1.0, 1e12]}),
     r"p.yaml: dynamics.load.torque must lie in \[1e-09, 1e\+09\] N·m or be 0 \(got 1e\+12\)"),
    (dict(load={"angle_deg": [0, 1e-9, 180], "torque": [1.0, 2.0, 3.0]}),
     r"p.yaml: dynamics.load.angle_deg must be at least 1e-06 deg apart, through 360 too"),
    (dict(load={"angle_deg": [1e-9, 360], "torque": [1.0, 2.0]}),
     r"p.yaml: dynamics.load.angle_deg must be at least 1e-06 deg apart, through 360 too"),
    (dict(reduction=1e4), r"p.yaml: dynamics.reduction must lie in \[0.001, 1000\] \(got 10000\)"),
    (dict(rtol=1e-15), r"p.yaml: dynamics.rtol must lie in \[1e-13, 0.01\] \(got 1e-15\)"),
    (dict(atol=1e-20), r"p.yaml: dynamics.atol must lie in \[1e-15, 0.01\] rad \(got 1e-20\)"),
    (dict(steady_tol=1e-14), r"p.yaml: dynamics.steady_tol must lie in \[1e-13, 0.01\]"),
    (dict(cycles=100_001), r"p.yaml: dynamics.cycles must be at most 100000 \(got 100001\)"),
])
def test_bad_dynamics_section(write_problem, changes, message):
    with pytest.raises(ProblemError, match=message):
        load_problem(problem_with(write_problem, **changes))


def test_section_is_a_mapping(write_problem):
    with pytest.raises(ProblemError, match=r"p.yaml: dynamics must be a mapping \(got list\)"):
        load_problem(write_problem(base_problem(dynamics=[1, 2])))


def test_stiffness_per_phase_count(write_problem, capsys):
    """One value or one per phase; the count is known only with the design (6 phases)."""
    path = problem_with(write_problem, stiffness=[2877.0, 2877.0, 2877.0])
    assert main(["simulate", str(path)]) == 2
    assert capsys.readouterr().err.strip() == (
        "optdesign: p.yaml: dynamics.stiffness must have one value or one per phase "
        "(got 3 for 6 phases)")


def test_section_is_checked_when_the_file_is_loaded(write_problem):
    """The per-phase rule holds at load, so analyze and solve refuse such a file too, not
    only simulate after its set-up."""
    with pytest.raises(ProblemError, match=r"dynamics\.stiffness must have one value"):
        load_problem(problem_with(write_problem, stiffness=[2877.0, 2877.0, 2877.0]))


def test_composite_takes_damping(write_problem):
    """A damped composite freewheel is a unilateral Kelvin-Voigt contact (docs/dynamics.md):
    accepted since it closes whenever the contact pushes again, not only at ε = 0."""
    problem = load_problem(problem_with(write_problem, damping_ratio=0.1, freewheel="composite"))
    assert problem.sections["dynamics"].damping_ratio == 0.1


@pytest.mark.parametrize("key, value", [
    ("I1", "1.0e-320"),          # denormal: λ/I1 overflows
    ("I2", "1.0e-320"),
    ("stiffness", "1.0e308"),    # λ·ε and λ/I overflow
    ("atol", "1.0e-320"),
    ("load", "1.0e308"),
])
def test_extreme_numbers_are_refused_at_load(tmp_path, capsys, key, value):
    """Denormal or huge inputs once reached scipy as inf/NaN ("array must not contain infs
    or NaNs", a traceback); now: exit 2 and one line naming the file and the key, before any
    integration. The YAML is written by hand so the numbers are exactly the user's text."""
    text = (ROOT / "problems" / "pulse_reducer_dynamics.yaml").read_text()
    lines = [f"  {key}: {value}" if line.startswith(f"  {key}:") else line
             for line in text.splitlines()]
    path = tmp_path / "extreme.yaml"
    path.write_text("\n".join(lines) + "\n")
    assert main(["simulate", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"extreme.yaml: dynamics.{key} must" in err[0]
    assert not (tmp_path / "out" / "dynamics.json").exists()


def test_simulate_needs_the_section(write_problem, capsys):
    path = write_problem(base_problem())
    assert main(["simulate", str(path)]) == 2
    assert capsys.readouterr().err.strip() == (
        "optdesign: p.yaml: dynamics is required by this command (add a dynamics: section)")


def test_bad_cycles_override(capsys):
    path = ROOT / "problems" / "pulse_reducer_dynamics.yaml"
    assert main(["simulate", str(path), "--cycles", "0"]) == 2
    assert "--cycles must be at least 1 (got 0)" in capsys.readouterr().err


def test_no_dynamics_under_analyze(write_problem, capsys):
    """The section parses, but analyze neither runs nor reports it: dynamics run under simulate only."""
    problem = load_problem(problem_with(write_problem))
    section = problem.sections["dynamics"]
    assert not hasattr(section, "analyze")
    assert section.stiffness == (2877.0,) and section.motor_b == 2.35
    assert main(["analyze", str(problem_with(write_problem)), "--json"]) == 0
    assert "dynamics" not in yaml.safe_load(capsys.readouterr().out)


def test_load_table_is_periodic():
    from optdesign.dynamics.model import Load
    from optdesign.dynamics.section import LoadTable

    load = Load(LoadTable((90.0, 270.0), (10.0, 20.0)))
    # 270° -> 90° + 360° closes the period: the value at 0 is halfway between 20 and 10
    assert load(0.0)[0] == pytest.approx(15.0, abs=1e-12)
    assert load(2 * 3.141592653589793)[0] == pytest.approx(15.0, abs=1e-9)
    assert load(3.141592653589793)[0] == pytest.approx(15.0, abs=1e-12)

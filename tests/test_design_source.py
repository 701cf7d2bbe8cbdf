"""One design through every command: ``solve`` writes design.yaml beside result.json, and every
command that evaluates a design takes it with ``--design`` (a result.json, a design.yaml, or a
front's pareto.csv with ``--point K`` or ``--knee``) and says which design it used."""
import csv
import json

import pytest
import yaml

from optdesign.cli import main
from tests.conftest import ROOT, run_main

DISC = ROOT / "problems" / "sharkov2022_disc.yaml"
DYNAMICS = ROOT / "problems" / "sharkov2022_dynamics.yaml"


@pytest.fixture(scope="module")
def solved(solved_disc):
    return solved_disc


def test_solve_writes_the_problem_with_its_optimum_fixed(solved):
    out, result = solved
    data = yaml.safe_load((out / "design.yaml").read_text())
    assert data["name"] == "sharkov2022_disc_design"
    assert data["design"] == result["design"]
    assert data["constraints"] == yaml.safe_load(DISC.read_text())["constraints"]
    # runnable as it is: its own design is the optimum, exactly
    code, text = run_main(["analyze", out / "design.yaml", "--json"])
    analysed = json.loads(text)
    assert code == 0 and analysed["design_source"] == "the file's design"
    assert analysed["strokes"]["forward"]["delta"] == result["delta"]


@pytest.mark.parametrize("name", ["result.json", "design.yaml"])
def test_analyze_takes_the_solved_design(solved, name):
    out, result = solved
    code, text = run_main(["analyze", DISC, "--design", out / name])
    first = text.splitlines()[0]
    assert code == 0
    assert first == f"design: {'the optimum' if name == 'result.json' else 'the design'} of " \
                    f"{out / name}; ω1 = 97 rad/s (926.3 rpm)"
    code, text = run_main(["analyze", DISC, "--design", out / name, "--json"])
    analysed = json.loads(text)
    assert analysed["design"] == result["design"]
    assert analysed["strokes"]["forward"]["delta"] == result["delta"]


def test_simulate_runs_the_solved_design_not_the_initial_one(solved, tmp_path):
    out, result = solved
    code, text = run_main(["simulate", DYNAMICS, "--design", out / "result.json", "--json",
                           "--out", tmp_path])
    simulated = json.loads(text)
    assert code == 0 and simulated["design_source"] == f"the optimum of {out / 'result.json'}"
    assert simulated["delta_kinematic"] == pytest.approx(result["delta"], rel=1e-6)
    code, text = run_main(["simulate", DYNAMICS, "--json", "--out", tmp_path])
    assert json.loads(text)["delta_kinematic"] > result["delta"] + 0.1


def _front(tmp_path, result):
    """A front's two files as a sweep writes them: a failed point, then two verified ones,
    the second the knee."""
    design = result["design"]
    rows = [{"phases": 6, "delta": "", "ratio": "", **{k: "" for k in design if k != "phases"},
             "status": "failed"},
            {"phases": 6, "delta": 0.2, "ratio": 0.4,
             **{k: v for k, v in design.items() if k != "phases"} | {"l3": 30.0},
             "status": "optimal"},
            {"phases": 6, "delta": result["delta"], "ratio": result["ratio"],
             **{k: v for k, v in design.items() if k != "phases"}, "status": "optimal"}]
    with open(tmp_path / "pareto.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    (tmp_path / "pareto.json").write_text(json.dumps({"knee": rows[2], "points": rows}))
    return tmp_path / "pareto.csv"


def test_a_point_of_a_front_or_its_knee(solved, tmp_path):
    _, result = solved
    front = _front(tmp_path, result)
    code, text = run_main(["analyze", DISC, "--design", front, "--point", "2", "--json"])
    analysed = json.loads(text)
    assert code == 0 and analysed["design"]["l3"] == 30.0
    assert analysed["design_source"].startswith(f"point 2 of the front {front} (δ = 0.2")
    code, text = run_main(["analyze", DISC, "--design", front, "--knee", "--json"])
    analysed = json.loads(text)
    assert analysed["design"] == result["design"]
    assert analysed["design_source"].startswith(f"the knee of the front {front}")


@pytest.mark.parametrize("argv,message", [
    (["--point", "1"], "--point picks a point of a front: give the front with --design"),
    (["--design", "{front}", "--point", "1"], "--point 1: that point of"),
    (["--design", "{local}", "--point", "1"], "is not an optimal design of the front (status "
                                              "'local': verified, but a design of its count "
                                              "beats it on its own ε-problem)"),
    (["--design", "{four}", "--point", "1"], "design.phases must be a whole number the "
                                             "problem admits (6; got 4)"),
    (["--design", "{front}", "--point", "4"], "--point must lie in [1, 3]"),
    (["--design", "{front}"], "a front holds many designs: pick one with --point K or --knee"),
    (["--design", "{front}", "--point", "2", "--knee"], "--point and --knee each pick a point"),
    (["--design", "{free}"], "design.l0 is not fixed"),
    (["--design", "{other}"], "its design is a slotted_lever design; sharkov2022_disc.yaml "
                              "is a fourbar_converter"),
    (["--design", "{reducer}", "--point", "1"], "point 1 is a pulse_reducer design; "
                                                "sharkov2022_disc.yaml is a fourbar_converter"),
    (["--design", "{part}", "--point", "1"], "point 1 has no l3 (a fourbar_converter design "
                                             "names every length"),
    (["--design", "{short}"], "its design has no l0 (a fourbar_converter design names every "
                              "length: l0, l1, l2, l2_prime, l3; none is taken from "
                              "sharkov2022_disc.yaml)"),
])
def test_a_design_that_cannot_be_taken_is_one_line_and_exit_2(solved, tmp_path, capsys,
                                                               argv, message):
    _, result = solved
    files = {"front": _front(tmp_path, result), "free": DISC,
             "other": tmp_path / "other.json", "reducer": tmp_path / "reducer.csv",
             "part": tmp_path / "part.csv", "short": tmp_path / "short.json"}
    files["other"].write_text(json.dumps({"mechanism": "slotted_lever", "design": {}}))
    # a pulse reducer's front (its lengths, its count's name and the generic count), and a
    # four-bar front row and a result.json each missing lengths: refused, not completed
    files["reducer"].write_text("freewheels,delta,ratio,r1,a,R1,status,count\n"
                                "2,0.001,0.99,20,100,50,optimal,2\n")
    files["part"].write_text("phases,delta,ratio,l0,l1,l2,l2_prime,status\n"
                             "6,0.3,0.5,225,20,225,100,optimal\n")
    row = "225,20,225,100,56"
    files["local"] = tmp_path / "local.csv"
    files["local"].write_text(f"phases,delta,ratio,l0,l1,l2,l2_prime,l3,status\n"
                              f"6,0.3,0.5,{row},local\n")
    files["four"] = tmp_path / "four.csv"
    files["four"].write_text(f"phases,delta,ratio,l0,l1,l2,l2_prime,l3,status\n"
                             f"4,0.3,0.5,{row},optimal\n")
    files["short"].write_text(json.dumps({"status": "optimal",
                                          "design": {"l3": 56, "phases": 6}}))
    argv = [a.format(**files) for a in argv]
    assert main(["analyze", str(DISC), *argv]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err, err


def test_a_long_name_still_makes_a_loadable_design_file(write_problem, tmp_path):
    """The loader's longest name (100 characters) plus _design would be refused: the design
    file's name is cut to fit."""
    from optdesign.problem.loader import MAX_NAME_CHARS, load_problem
    from tests.conftest import file_data

    path = write_problem(file_data(DISC, name="n" * MAX_NAME_CHARS,
                                   design={"l0": 225, "l1": 20, "l2": 225, "l2_prime": 100,
                                           "l3": 56, "phases": 6}))
    code, _ = run_main(["solve", path, "--out", tmp_path / "out", "--no-plots"])
    assert code == 0
    fixed = load_problem(tmp_path / "out" / "design.yaml")
    assert len(fixed.name) == MAX_NAME_CHARS and fixed.name.endswith("_design")


@pytest.mark.parametrize("key", ["l0", "phases"])
def test_a_huge_integer_in_a_design_file_is_exit_2(tmp_path, capsys, key):
    """JSON's integers have no bound: one of 400 digits is no length and no count."""
    design = {"l0": 225, "l1": 20, "l2": 225, "l2_prime": 100, "l3": 56, "phases": 6}
    path = tmp_path / "result.json"
    path.write_text(json.dumps({"design": design | {key: 10 ** 400}}))
    assert main(["analyze", str(ROOT / "problems" / "sharkov2022.yaml"), "--design",
                 str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"design.{key} must be a positive number" in err, err

"""An output folder keeps its problem file's results: another file's run is refused (exit 2,
one line) unless --force, the same file (edited) goes on, and a failed solve never replaces
an earlier optimum (optdesign.outputs.provenance, optdesign.commands.solve)."""
import json

from optdesign.commands.files import SOLVE_FILES
from optdesign.outputs.provenance import SOURCE, resolved
from tests.conftest import ROOT, run_main

PAPER = ROOT / "problems" / "sharkov2022.yaml"


def test_a_second_file_is_refused_at_the_first_files_folder(tmp_path, capsys):
    out = tmp_path / "results"
    assert run_main(["export", PAPER, "--out", out, "--format", "csv"])[0] == 0
    assert json.loads((out / SOURCE).read_text()) == {"problem": resolved(PAPER)}
    other = tmp_path / "copy.yaml"                     # the same name: inside, another file
    other.write_text(PAPER.read_text())
    before = (out / "trajectories.csv").read_bytes()
    capsys.readouterr()
    assert run_main(["export", other, "--out", out, "--format", "csv"])[0] == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "holds the results of" in err[0] and "copy.yaml" in err[0] \
        and "--force to replace them" in err[0], err
    assert (out / "trajectories.csv").read_bytes() == before
    assert run_main(["export", other, "--out", out, "--format", "csv", "--force"])[0] == 0
    assert json.loads((out / SOURCE).read_text()) == {"problem": resolved(other)}


def test_the_same_file_edited_runs_again_without_force(tmp_path):
    problem = tmp_path / "p.yaml"
    problem.write_text(PAPER.read_text())
    out = tmp_path / "results"
    assert run_main(["export", problem, "--out", out, "--format", "csv"])[0] == 0
    problem.write_text(PAPER.read_text().replace("input_speed: 97.0", "input_speed: 90.0"))
    assert run_main(["export", problem, "--out", out, "--format", "csv"])[0] == 0


def test_a_failed_solve_keeps_the_earlier_optimum(tmp_path, monkeypatch, capsys):
    import optdesign.solver
    from optdesign.solver.result import SolveResult

    out = tmp_path / "results"
    out.mkdir()
    earlier = {name: f"the earlier {name}" for name in SOLVE_FILES if name != "result.json"
               and name != "failed_result.json"}
    for name, text in earlier.items():
        (out / name).write_text(text)
    (out / "result.json").write_text(json.dumps({"status": "optimal"}))
    (out / SOURCE).write_text(json.dumps({"problem": resolved(PAPER)}))

    def failed(problem, progress=None):
        return SolveResult(name=problem.name, status="failed", design=None, delta=None,
                           ratio=None, min_transmission_angle_deg=None, solve_time_s=0.0,
                           iterations=0, per_phase=[], objective={}, accuracy={},
                           message="no start converged")

    monkeypatch.setattr(optdesign.solver, "solve", failed)
    assert run_main(["solve", PAPER, "--out", out, "--no-plots"])[0] == 1
    err = capsys.readouterr().err
    assert "the earlier optimum" in err and "failed_result.json" in err
    assert json.loads((out / "result.json").read_text()) == {"status": "optimal"}
    assert all((out / name).read_text() == text for name, text in earlier.items())
    assert json.loads((out / "failed_result.json").read_text())["status"] == "failed"

"""``optdesign tolerance``: its files, its JSON (units included), its terminal table and its
refusals."""
import json

import pytest

from optdesign.cli import main
from optdesign.outputs.atomic import SCHEMA_VERSION
from optdesign.tolerance.report import format_tolerance
from tests.conftest import ROOT, run_main
from tests.test_units import unlisted
from tests.tolerance.conftest import paper

EXAMPLE = ROOT / "problems" / "sharkov2022_disc_tolerance.yaml"


run = run_main


@pytest.fixture(scope="module")
def solved(tmp_path_factory):
    """The example run on a design given as a solve's result.json (--json printed)."""
    tmp = tmp_path_factory.mktemp("tolerance")
    design = {"l0": 230.0, "l1": 20.0, "l2": 220.0, "l2_prime": 95.0, "l3": 58.0, "phases": 6}
    (tmp / "result.json").write_text(json.dumps({"status": "optimal", "design": design,
                                                 "mechanism": "fourbar_converter"}))
    code, out = run(["tolerance", EXAMPLE, "-o", tmp / "out", "--samples", 1500, "--seed", 7,
                     "--design", tmp / "result.json", "--json"])
    return tmp, code, json.loads(out), design


def test_files_and_keys(solved):
    tmp, code, doc, design = solved
    assert code == 0
    written = json.loads((tmp / "out" / "tolerance.json").read_text())
    assert written == doc
    assert doc["design"] == {k: float(v) for k, v in design.items()}
    assert "result.json" in doc["design_source"]
    assert doc["tolerances_mm"]["l1"] == 0.02 and doc["tolerances_mm"]["l3"] == 0.05
    mc, nominal = doc["monte_carlo"], doc["nominal"]
    assert mc["parts"] == 1500 and mc["seed"] == 7
    wd, wa = doc["worst_case"]["delta"], doc["worst_case"]["transmission_angle"]
    assert wd["delta"] >= mc["delta_distribution"]["max"] >= nominal["delta"]
    assert wa["mu_min_deg"] <= mc["mu_min_deg_distribution"]["min"] <= nominal["mu_min_deg"]
    assert 0 <= mc["share_below_min_ratio"] <= 1           # the file's min_ratio: 0.344
    assert doc["schema_version"] == SCHEMA_VERSION and unlisted(doc) == set()
    rows = (tmp / "out" / "tolerance.csv").read_text().splitlines()
    assert rows[0] == ("l0_offset_mm,l1_offset_mm,l2_offset_mm,l2_prime_offset_mm,"
                       "l3_offset_mm,delta,ratio,mu_min_deg,assembles")
    assert len(rows) == 1501
    assert (tmp / "out" / "tolerance.png").read_bytes()[:4] == b"\x89PNG"


def test_every_quantity_of_the_nominal_and_of_the_worst_parts_exactly(solved):
    """The tolerance report carries every quantity (the vocabulary of analyze), exact, of the
    nominal and of both worst parts; the worst-δ part's ripple is its worst-case δ."""
    from optdesign.quantities import known

    doc = solved[2]
    nominal = doc["nominal"]["quantities"]["values"]
    assert set(nominal) == set(known())
    assert nominal["ripple"] == pytest.approx(doc["nominal"]["delta"], rel=1e-9)
    worst = doc["worst_case"]["delta"]
    assert worst["quantities"]["values"]["ripple"] == pytest.approx(worst["delta"], rel=1e-9)
    assert doc["units"]["housing_radius"] == "mm"
    text = format_tolerance(doc)
    row = next(line for line in text.splitlines() if line.startswith("housing_radius"))
    assert float(row.split()[1]) == pytest.approx(nominal["housing_radius"], rel=1e-5)


def test_parts_that_break_a_rule_point_at_the_robust_solve(solved):
    """A box whose parts all keep the rules says nothing more; one where some break the angle
    rule names the objective that sizes a design for the whole box."""
    doc = solved[2]
    hint = "objective: {robust: worst_case}"
    assert (hint in format_tolerance(doc)) == \
        (doc["monte_carlo"]["share_below_min_transmission_angle"] > 0 or
         doc["monte_carlo"]["share_not_assembling"] > 0)
    failing = {**doc, "monte_carlo": {**doc["monte_carlo"],
                                      "share_below_min_transmission_angle": 0.837}}
    assert hint in format_tolerance(failing)
    quiet = {**doc, "monte_carlo": {**doc["monte_carlo"], "share_not_assembling": 0.0,
                                    "share_below_min_transmission_angle": 0.0}}
    assert hint not in format_tolerance(quiet)


def test_the_terminal_table(solved):
    text = format_tolerance(solved[2])
    assert text.startswith("sharkov2022_disc_tolerance: tolerance analysis of the optimum of ")
    assert "l1 ±0.02" in text and "worst δ part:" in text and "least μ part:" in text
    lines = {line.split()[0]: line.split() for line in text.splitlines() if line.strip()}
    assert float(lines["δ"][1]) == pytest.approx(solved[2]["nominal"]["delta"], abs=1e-6)


@pytest.mark.parametrize("content, message", [
    ("{not json", "is not JSON"),
    ('{"design": null}', "has no design object"),
    ('{"design": {"l9": 3}}', "design.l9 is not a design key"),
    ('{"design": {"l3": -1}}', "design.l3 must be a positive number"),
    ('{"design": {"l3": 56}, "mechanism": "slotted_lever"}',
     "its design is a slotted_lever design; "),
    ('{"design": {"l3": 56, "phases": 6}}', "its design has no l0"),
    ('{"design": {"l3": 56, "phases": 2.5}}', "design.phases must be a whole number the "
                                               "problem admits (6; got 2.5)"),
    ('{"design": {"l3": 56, "phases": 100000}}', "design.phases must be a whole number"),
    ("x" * (1 << 20) + "y", "is larger than 1024 KiB"),
])
def test_a_bad_design_file_is_exit_2(content, message, tmp_path, capsys):
    (tmp_path / "r.json").write_text(content)
    assert main(["tolerance", str(EXAMPLE), "--design", str(tmp_path / "r.json"),
                 "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err


def test_a_free_phase_count_needs_a_design(write_problem, capsys):
    data = paper(tolerances={"default": 0.05})
    data["design"]["phases"] = {"choices": [4, 6]}
    assert main(["tolerance", str(write_problem(data))]) == 2
    assert "design.phases is free; give a solved design with --design" in \
        capsys.readouterr().err


@pytest.mark.parametrize("argv", [["--samples", "0"], ["--seed", "-1"]])
def test_bad_arguments_are_exit_2(argv, tmp_path):
    assert main(["tolerance", str(EXAMPLE), "--out", str(tmp_path)] + argv) == 2


def test_a_bad_out_is_exit_2_before_any_work(tmp_path, capsys, monkeypatch):
    def called(*a, **k):
        raise AssertionError("the Monte Carlo ran before the output folder was checked")
    monkeypatch.setattr("optdesign.tolerance.montecarlo.monte_carlo", called)
    (tmp_path / "f").write_text("x")
    assert main(["tolerance", str(EXAMPLE), "--out", str(tmp_path / "f")]) == 2
    assert "exists and is not a folder" in capsys.readouterr().err


def test_a_design_that_is_a_device_is_refused_at_once(tmp_path, capsys):
    assert main(["tolerance", str(EXAMPLE), "--design", "/dev/zero", "--out",
                 str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "is not a regular file" in err

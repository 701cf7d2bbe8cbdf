"""``optdesign analyze``: the contract's JSON, exit codes, and no plotting import."""
import json
import subprocess
import sys

import pytest

from optdesign.cli import main
from tests.conftest import ROOT, base_problem

PAPER_FILE = str(ROOT / "problems" / "sharkov2022.yaml")


def test_analyze_json_contract(capsys):
    assert main(["analyze", PAPER_FILE, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["assembles"] is True
    assert set(out["strokes"]) == {"forward", "reverse"}
    keys = {"omega_max", "omega_min", "omega_midrange", "omega_avg", "omega_mean", "delta",
            "delta_mean", "ratio"}
    for stroke in out["strokes"].values():
        assert keys <= set(stroke)
    fwd = out["strokes"]["forward"]
    assert fwd["delta"] == pytest.approx(0.376, abs=5e-4)        # paper, rounded to 0.001
    # Chain 3's |cos μ| peaks at 0.5487: min(μ, 180° - μ) = acos 0.5487 = 56.72° (not the
    # pressure angle 90° - 68.39° = 21.61° of chain 6, which an earlier formula gave).
    assert out["min_transmission_angle_deg"] == pytest.approx(56.72, abs=0.01)
    assert [r["eccentricity"] for r in out["regulation"]] == [1.0, 0.5, 0.25]


def test_analyze_table(capsys):
    assert main(["analyze", PAPER_FILE]) == 0
    out = capsys.readouterr().out
    assert "forward" in out and "0.3764" in out


def test_design_that_does_not_assemble_names_chain_and_angle(write_problem, capsys):
    data = base_problem()
    data["design"]["l3"] = 20          # rocker too short to reach the coupler
    assert main(["analyze", str(write_problem(data)), "--json"]) == 1
    out = json.loads(capsys.readouterr().out)
    assert out["assembles"] is False
    assert out["failure"]["chain"] >= 1 and 0 <= out["failure"]["phi_deg"] < 360
    assert "does not assemble at crank angle" in out["failure"]["message"]


def test_analyze_imports_no_plotting_module():
    code = ("import sys; from optdesign.cli import main; main(['analyze', %r, '--json']); "
            "bad = [m for m in sys.modules if m.split('.')[0] in ('matplotlib', 'dask', 'pandas')]; "
            "sys.exit(1 if bad else 0)" % PAPER_FILE)
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr


SPREADER = ROOT / "problems" / "spreader.yaml"


def test_analyze_over_choices_evaluates_every_count(capsys):
    """phases: {choices: [4, 5, 6, 8]}: a row per count, the JSON per count, the first
    count's keys as before; each count's δ is that count's own."""
    assert main(["analyze", str(SPREADER), "--json"]) == 1       # the ratio floor: violated
    out = json.loads(capsys.readouterr().out)
    assert [c["count"] for c in out["per_count"]] == [4, 5, 6, 8]
    assert out["design"]["phases"] == 4 and out["per_count"][0]["design"]["phases"] == 4
    deltas = [c["delta_named"]["worst"]["delta"] for c in out["per_count"]]
    assert out["delta_named"]["worst"]["delta"] == deltas[0]
    assert deltas == sorted(deltas, reverse=True) and len(set(deltas)) == 4
    assert main(["analyze", str(SPREADER)]) == 1
    text = capsys.readouterr().out
    assert "every admissible count (phases: 4, 5, 6, 8)" in text
    for n, d in zip([4, 5, 6, 8], deltas):
        assert f"  {n:>5}  {d:9.6f}" in text


def test_analyze_phases_picks_one_count_or_names_the_admissible(capsys):
    assert main(["analyze", str(SPREADER), "--phases", "6", "--json"]) == 1
    out = json.loads(capsys.readouterr().out)
    assert out["design"]["phases"] == 6 and "per_count" not in out
    assert main(["analyze", str(SPREADER), "--phases", "7"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["optdesign: spreader.yaml: --phases 7 is not an admissible count of "
                   "design.phases (admissible: 4, 5, 6, 8)"]


def test_analysis_summary_names_its_delta():
    from optdesign import analyze

    text = analyze(PAPER_FILE).summary()
    assert "δ (midrange, worst over e = 1, 0.5, 0.25, at e = 1) = 0.376413" in text

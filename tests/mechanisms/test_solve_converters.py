"""``solve`` on the slotted lever and the pulse reducer: the generic NLP, checked by closed forms
and by the exact evaluator."""
import json
import math

import pytest

from optdesign.cli import main
from optdesign.evaluation.design import Design
from optdesign.envelope.exact import exact_figures
from optdesign.problem.loader import load_problem
from optdesign.solver import solve
from tests.conftest import ROOT


def test_vergov_solve_puts_XD_at_the_ratio_bound():
    """δ and the ratio of stroke ``both`` both fall as XD grows (docs/mechanisms.md), so the least
    ripple with ratio >= 0.2 sits where the ratio bound binds; five sections beat three."""
    problem = load_problem(ROOT / "problems" / "vergov_solve.yaml")
    result = solve(problem)
    assert result.status == "optimal"
    assert result.design["sections"] == 5
    assert result.ratio == pytest.approx(0.2, abs=1e-6)
    xd = result.design["XD"]
    assert xd == pytest.approx(414.54, abs=0.05)
    # the exact evaluator, independently: at the optimum, and a little further out
    f, _ = exact_figures(Design("slotted_lever", result.design), "both", 0.628)
    assert f.delta == pytest.approx(result.delta, rel=1e-9)
    beyond, _ = exact_figures(Design("slotted_lever", result.design | {"XD": xd + 0.5}),
                              "both", 0.628)
    assert beyond.ratio < 0.2 and beyond.delta < f.delta
    three = next(p for p in result.per_phase if p.phases == 3)
    assert three.status == "optimal" and three.delta > result.delta


def test_pulse_reducer_solve_cli(tmp_path, capsys):
    """Largest ratio with δ <= 0.7: n = 2 (δ = 2) is infeasible, n = 4 (δ = 2·tan²(π/8) = 0.343)
    wins, with r1 at its limit r = 1 - assembly_margin, so the ratio is
    0.999·(a/R1)·4·sin(π/4)/π (closed form, docs/mechanisms.md)."""
    path = ROOT / "problems" / "pulse_reducer_solve.yaml"
    assert main(["solve", str(path), "--out", str(tmp_path), "--json", "--no-plots"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["status"] == "optimal"
    assert out["design"]["freewheels"] == 4
    assert out["design"]["r1"] == pytest.approx(0.999 * 50.0, rel=1e-6)
    assert out["delta"] == pytest.approx(2 * math.tan(math.pi / 8) ** 2, rel=1e-9)
    assert out["ratio"] == pytest.approx(0.999 * 50 / 250 * 4 * math.sin(math.pi / 4) / math.pi,
                                         rel=1e-6)
    statuses = {p["phases"]: p["status"] for p in out["per_phase"]}
    assert statuses == {2: "infeasible", 3: "optimal", 4: "optimal"}
    assert (tmp_path / "result.json").exists()

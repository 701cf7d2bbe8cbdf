"""The analogue curves and ``optdesign curves`` for every registered mechanism."""
import subprocess
import sys

import numpy as np
import pytest
import yaml

from optdesign.cli import main
from optdesign.analyses.curves import member_curves, plot_curves
from optdesign.evaluation.design import Design
from optdesign.mechanisms import known
from optdesign.mechanisms.pulse_reducer import paper_position
from tests.conftest import ROOT, base_problem

PROBLEMS = {"fourbar_converter": "sharkov2022", "pulse_reducer": "pulse_reducer",
            "slotted_lever": "vergov"}


def test_every_mechanism_has_a_problem_file_here():
    assert set(PROBLEMS) == set(known())


def test_reducer_output_is_the_papers_position_function():
    """Φ from the trapezoid integral of the envelope against eqs. (1)-(2): the trapezoid error
    h²/12·∫|Φ'''| dφ with h = 2π/1440 is about 1.3e-7 rad (of 0.08 per turn); bound 5e-7."""
    d = Design("pulse_reducer", dict(r1=5.0, a=50.0, R1=250.0, freewheels=2))
    c = member_curves(d, "forward")
    paper = np.array([float(paper_position(x, 0.1, 5.0)) for x in c.phi])
    assert np.max(np.abs(c.output_position - paper)) < 5e-7
    below, above = (int(np.argmin(np.abs(c.phi - np.pi - s * 1e-9))) for s in (-1, 1))
    assert 0 < c.phi[above] - c.phi[below] < 3e-9                     # the breakpoint, both sides
    assert c.output_acceleration[below] == pytest.approx(-0.1 / (5.0 * 1.1), rel=1e-6)
    assert c.output_acceleration[above] == pytest.approx(0.1 / (5.0 * 0.9), rel=1e-6)


def test_slotted_lever_both_strokes_output_is_the_absolute_speed():
    d = Design("slotted_lever", dict(XD=292.0, L=74.0, sections=1))
    c = member_curves(d, "both", n_samples=721)
    assert np.allclose(c.output_speed, np.abs(c.dtheta[0]), atol=1e-15)
    assert c.output_position[-1] == pytest.approx(8 * np.arcsin(74 / 510), rel=1e-5)


def test_plot_curves_draws_into_given_axes():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    d = Design("slotted_lever", dict(XD=292.0, L=74.0, sections=2))
    fig, axes = plt.subplots(3, 2)
    assert plot_curves(member_curves(d, "forward", n_samples=181), axes=axes) is fig
    assert len(axes[0, 0].lines) == 2 + 1              # two sections and the zero line
    plt.close(fig)


@pytest.mark.parametrize("mechanism", sorted(PROBLEMS))
def test_cli_curves_writes_a_png(tmp_path, capsys, mechanism):
    problem = ROOT / "problems" / f"{PROBLEMS[mechanism]}.yaml"
    assert main(["curves", str(problem), "--out", str(tmp_path), "--samples", "181"]) == 0
    png = tmp_path / "curves.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # no temp file left; the record of the problem file beside the figure
    assert sorted(p.name for p in tmp_path.iterdir()) == [".optdesign-source.json", "curves.png"]
    first, second = capsys.readouterr().out.splitlines()
    assert first.startswith("design: the file's design; ω1 = ") and second == str(png)


@pytest.mark.parametrize("args, message", [
    (["--eccentricity", "0"], "optdesign: --eccentricity must lie in (0, 1] (got 0)"),
    (["--samples", "3"], "optdesign: --samples must be at least 16 (got 3)"),
])
def test_cli_curves_bad_options(tmp_path, capsys, args, message):
    problem = ROOT / "problems" / "vergov.yaml"
    assert main(["curves", str(problem), "--out", str(tmp_path)] + args) == 2
    assert capsys.readouterr().err.strip() == message


def test_cli_curves_missing_file(tmp_path, capsys):
    assert main(["curves", str(tmp_path / "nope.yaml")]) == 2
    assert "nope.yaml: no such file" in capsys.readouterr().err


def test_cli_curves_design_that_does_not_assemble(tmp_path, write_problem, capsys):
    data = base_problem()
    data["design"]["l3"] = 5
    assert main(["curves", str(write_problem(data)), "--out", str(tmp_path)]) == 1
    assert "does not assemble at crank angle" in capsys.readouterr().err
    assert not (tmp_path / "curves.png").exists()


def test_analyze_does_not_load_matplotlib():
    code = ("import sys; from optdesign.cli import build_parser; build_parser(); "
            "import optdesign.analyses.analyze, optdesign.analyses.curves; "
            "print('matplotlib' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=ROOT, check=True)
    assert out.stdout.strip() == "False"

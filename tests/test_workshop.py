"""From optimum to workshop: ``solve``, then ``export`` (the linkage to scale as DXF, read back
here with ezdxf; the same drawing as SVG, rendered in headless Chromium; its trajectories as CSV)
and ``animate`` (a self-contained HTML page, rendered in Chromium, and a GIF) on its design."""
import math

import numpy as np
import pytest

from optdesign.cli import main
from tests.conftest import ROOT, chromium_run, run_main

DISC = ROOT / "problems" / "sharkov2022_disc.yaml"


@pytest.fixture(scope="module")
def exported(solved_disc, tmp_path_factory):
    solved, result = solved_disc
    out = tmp_path_factory.mktemp("exported")
    code, text = run_main(["export", DISC, "--design", solved / "design.yaml",
                           "--angle", "30", "--out", out / "export"])
    assert code == 0
    assert text.splitlines()[0] == f"design: the design of {solved / 'design.yaml'}; " \
                                   f"ω1 = 97 rad/s (926.3 rpm)"
    return out / "export", result


def test_the_dxf_reads_back_with_the_lengths_to_1e_9_mm(exported):
    import ezdxf

    out, result = exported
    design = result["design"]
    doc = ezdxf.readfile(out / "linkage.dxf")
    assert doc.units == ezdxf.units.MM
    # the title's values at full precision, as custom header properties
    for k in ("l0", "l1", "l2", "l2_prime", "l3"):
        assert float(doc.header.custom_vars.get(f"{k} (mm)")) == pytest.approx(design[k],
                                                                                abs=1e-9)
    assert int(doc.header.custom_vars.get("phases")) == 6
    # the drawing itself: every link's line as long as its length, to 1e-9 mm
    lines = {}
    for line in doc.modelspace().query("LINE"):
        start, end = np.array(line.dxf.start)[:2], np.array(line.dxf.end)[:2]
        lines.setdefault(line.dxf.layer, []).append(float(np.hypot(*(end - start))))
    assert lines["CRANK"] == pytest.approx([design["l1"]], abs=1e-9)
    assert lines["ROCKER"] == pytest.approx([design["l3"]] * 6, abs=1e-9)
    assert lines["FRAME"] == pytest.approx([design["l0"]] * 6, abs=1e-9)     # O to O_i
    couplers = lines["COUPLER"]
    assert sum(abs(x - design["l2"]) < 1e-9 for x in couplers) == 1           # A B1
    assert sum(abs(x - design["l2_prime"]) < 1e-9 for x in couplers) == 5     # C_i B_i
    pin = design["l2"] - design["l2_prime"]
    assert sum(abs(x - pin) < 1e-9 for x in couplers) == 5                    # A C_i
    # the crank at 30° and a swing arc per rocker
    crank = next(iter(doc.modelspace().query('LINE[layer=="CRANK"]')))
    start, end = np.array(crank.dxf.start)[:2], np.array(crank.dxf.end)[:2]
    tip = end if np.hypot(*start) < 1e-9 else start
    assert math.degrees(math.atan2(tip[1], tip[0])) == pytest.approx(30.0, abs=1e-9)
    assert len(doc.modelspace().query('ARC[layer=="PATHS"]')) == 6
    assert {"FRAME", "CRANK", "COUPLER", "ROCKER", "PATHS", "TITLE"} <= \
        {layer.dxf.name for layer in doc.layers}


def test_the_svg_is_the_drawing_and_chromium_draws_it(exported, chromium, tmp_path):
    from PIL import Image

    out, _ = exported
    svg = (out / "linkage.svg").read_text()
    assert svg.lstrip().startswith("<?xml") and "<svg" in svg and 'width="' in svg
    page = tmp_path / "page.html"
    page.write_text(f'<html><body style="margin:0"><img src="{out / "linkage.svg"}" '
                    f'style="width:900px"></body></html>')
    shot = tmp_path / "linkage.png"
    chromium_run(chromium, tmp_path, f"--screenshot={shot}", "--window-size=920,1100",
                 page.as_uri())
    pixels = np.asarray(Image.open(shot).convert("RGB")).astype(int)
    r, g, b = pixels[..., 0], pixels[..., 1], pixels[..., 2]
    # each layer's colour on the page (lines under a pixel wide: their hue, not full colour)
    assert ((r - np.maximum(g, b)) > 60).sum() > 20              # the crank, red
    assert ((b - np.maximum(r, g)) > 60).sum() > 1000            # the couplers, blue
    assert ((g - np.maximum(r, b)) > 40).sum() > 150             # the rockers, green
    assert (pixels.sum(axis=2) < 300).sum() > 2000               # the title block, black


def test_the_trajectories_are_the_motion_over_a_turn(exported):
    import pandas as pd

    out, result = exported
    table = pd.read_csv(out / "trajectories.csv")
    assert len(table) == 360 and table["phi_deg"].iloc[1] == pytest.approx(1.0)
    design = result["design"]
    crank = np.hypot(table["A_x_mm"] - table["O_x_mm"], table["A_y_mm"] - table["O_y_mm"])
    rocker = np.hypot(table["B3_x_mm"] - table["O3_x_mm"], table["B3_y_mm"] - table["O3_y_mm"])
    assert np.allclose(crank, design["l1"], atol=1e-8)
    assert np.allclose(rocker, design["l3"], atol=1e-8)
    # ω_k is ω1·dθ_k/dφ: its integral over the turn is θ_k's change (none, it swings back)
    w1 = 97.0
    dtheta = np.gradient(np.unwrap(table["theta_1_rad"]), np.radians(1.0)) * w1
    assert np.allclose(dtheta[2:-2], table["omega_1_rad_s"][2:-2], rtol=1e-3, atol=1e-2)
    # the output envelope's samples never exceed the exact peak, and come within 0.1 % of it
    peak = table["omega_out_rad_s"].max()
    exact = result["quantities"]["values"]["peak_speed"]
    assert exact * 0.999 < peak <= exact * (1 + 1e-12)
    assert {f"epsilon_{k}_rad_s2" for k in range(1, 7)} <= set(table.columns)


def test_a_format_not_known_is_exit_2(tmp_path, capsys):
    assert main(["export", str(DISC), "--format", "dxf,step", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--format takes dxf, svg and csv" in err


# --------------------------------------------------------------------------- animate
@pytest.fixture(scope="module")
def animated(exported, solved_disc):
    out, result = exported
    solved = solved_disc[0]
    code, text = run_main(["animate", DISC, "--design", solved / "result.json",
                           "--out", out.parent / "animated"])
    assert code == 0 and text.startswith(f"design: the optimum of {solved / 'result.json'}")
    return out.parent / "animated", result


def _page_data(html: str) -> dict:
    import json

    start = html.index("const D = ") + len("const D = ")
    return json.loads(html[start:html.index(";\n", start)])


def test_the_page_is_self_contained_and_its_data_is_the_turn(animated):
    out, result = animated
    html = (out / "animation.html").read_text()
    for outside in ("<script src", "<link", "src=\"http", "href=\"http", "@import", "url("):
        assert outside not in html
    data = _page_data(html)
    assert len(data["phi"]) == 120 and len(data["positions"]) == 120
    speeds, output = np.array(data["speeds"]), np.array(data["output"])
    # the highlighted member is the one whose driving speed is the output's, frame by frame
    assert np.allclose(speeds[data["driving"], np.arange(120)], output, atol=1e-4)
    assert 0.99 * result["quantities"]["values"]["peak_speed"] < output.max() <= \
        result["quantities"]["values"]["peak_speed"] * (1 + 1e-5)
    assert sorted({m for *_, m in data["links"] if m is not None}) == list(range(6))


def test_chromium_turns_the_crank(animated, chromium, tmp_path):
    import re

    from PIL import Image

    out, _ = animated
    page = (out / "animation.html").as_uri()
    dom = chromium_run(chromium, tmp_path, "--virtual-time-budget=1500", "--dump-dom", page)
    assert int(re.search(r'data-frames-shown="(\d+)"', dom).group(1)) >= 1
    assert re.search(r"crank angle [\d.]+° · member \d drives · output [\d.]+ rad/s", dom)
    shot = tmp_path / "animation.png"
    chromium_run(chromium, tmp_path, "--virtual-time-budget=1500", f"--screenshot={shot}",
                 "--window-size=1200,760", page)
    pixels = np.asarray(Image.open(shot).convert("RGB")).astype(int)
    r, g, b = pixels[..., 0], pixels[..., 1], pixels[..., 2]
    assert ((b - np.maximum(r, g)) > 80).sum() > 1000                       # couplers
    assert ((r > 200) & (g > 100) & (g < 170) & (b < 60)).sum() > 30        # driving, orange
    assert (pixels.sum(axis=2) < 150).sum() > 1000                          # the envelope


def test_the_gif_turns_the_crank_once(animated):
    from PIL import Image

    out, _ = animated
    gif = Image.open(out / "animation.gif")
    assert gif.format == "GIF" and gif.n_frames == 60 and gif.size[0] >= 600
    first = np.asarray(gif.convert("RGB")).copy()
    gif.seek(30)
    assert np.abs(np.asarray(gif.convert("RGB")).astype(int) - first).sum() > 0


# --------------------------------------------------------------------------- compare, and all
def test_compare_puts_the_optimum_beside_the_initial_design(exported, solved_disc, tmp_path):
    import json

    out, result = exported
    solved = solved_disc[0]
    code, text = run_main(["compare", solved / "result.json", solved / "design.yaml", DISC,
                           "--json", "--out", tmp_path])
    doc = json.loads(text)
    assert code == 0 and [r["label"] for r in doc["designs"]] == [
        str(solved / "result.json"), str(solved / "design.yaml"), str(DISC)]
    optimum, fixed, initial = doc["designs"]
    assert optimum["delta"] == result["delta"] and fixed["delta"] == result["delta"]
    assert optimum["housing_radius"] == result["quantities"]["values"]["housing_radius"]
    assert initial["l3"] == 56.0 and initial["delta"] > result["delta"]
    assert doc["units"]["l3"] == "mm" and doc["units"]["housing_radius"] == "mm"
    assert (tmp_path / "compare.png").stat().st_size > 20_000
    assert (tmp_path / "compare.csv").read_text().startswith("label,")


def test_one_design_through_every_command(exported, solved_disc, tmp_path):
    """From a fresh clone: solve the disc problem, then export, animate, simulate and compare
    on its design.yaml and result.json (the solve in conftest, export and animate above)."""
    import json

    out, result = exported
    solved = solved_disc[0]
    dynamics = ROOT / "problems" / "sharkov2022_dynamics.yaml"
    code, text = run_main(["simulate", dynamics, "--design", solved / "design.yaml", "--json",
                           "--out", tmp_path / "simulated"])
    simulated = json.loads(text)
    assert code == 0 and simulated["delta_kinematic"] == pytest.approx(result["delta"],
                                                                       rel=1e-6)
    assert simulated["design_source"] == f"the design of {solved / 'design.yaml'}"
    code, _ = run_main(["compare", solved / "design.yaml", solved / "result.json",
                        "--out", tmp_path / "compared"])
    assert code == 0
    assert {p.name for p in out.iterdir()} == {"linkage.dxf", "linkage.svg",
                                               "trajectories.csv", ".optdesign-source.json"}
    assert {p.name for p in (out.parent / "animated").iterdir()} >= {"animation.html",
                                                                    "animation.gif"}

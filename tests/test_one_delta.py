"""One δ, named: the spreader problem's outputs (terminal, result.json, speeds.png,
mechanism.png, the animation, the DXF title block, compare, the design-space notebook) give the
same δ for the same eccentricity, each labelled in the same words
(optdesign.evaluation.ripples); compared as text read from the files, not as pixels."""
import json
import re

import yaml

from optdesign.evaluation.ripples import ripple_label
from tests.conftest import ROOT, executed_notebook, run_main

#: the spreader problem's optimum (n = 8; δ 0.0790 at e = 1, 0.0811 at e = 0.3)
OPTIMUM = dict(l0=275.9282475594937, l1=12.0, l2=279.9999992641218, l2_prime=249.99999918263197,
               l3=28.40016037835361, phases=8)
#: "δ (midrange, at e = 1) = 0.0790" or "δ (midrange, worst over e = 1, 0.3, at e = 0.3) = ..."
NAMED = re.compile(r"δ \(midrange, (worst over e = 1, 0\.3, )?at e = ([\d.]+)\)(?: =|:) ([\d.]+)")


def _named(text: str) -> set[tuple[bool, float, float]]:
    """(is the worst, e, δ to 4 decimals) of every named δ in ``text``."""
    return {(bool(w), float(e), round(float(d), 4)) for w, e, d in NAMED.findall(text)}


def test_every_output_of_the_spreader_names_the_same_delta(tmp_path):
    from PIL import Image

    data = yaml.safe_load((ROOT / "problems" / "spreader.yaml").read_text())
    data["design"] = dict(OPTIMUM)
    problem = tmp_path / "spreader.yaml"
    problem.write_text(yaml.safe_dump(data))
    out = tmp_path / "solved"
    code, terminal = run_main(["solve", problem, "--out", out])
    assert code == 0
    expected = {(True, 0.3, 0.0811), (False, 1.0, 0.079), (False, 0.3, 0.0811)}
    assert _named(terminal) == expected
    assert "δ (midrange, worst over e = 1, 0.3, at e = 0.3) = 0.081097" in terminal

    result = json.loads((out / "result.json").read_text())
    named = result["delta_named"]
    assert named["worst"]["label"] == ripple_label("midrange", 0.3, (1.0, 0.3))
    assert named["worst"]["delta"] == result["delta"]
    assert _named("; ".join(f"{r['label']} = {r['delta']}" for r in
                            [named["worst"], *named["each"]])) == expected

    speeds = Image.open(out / "speeds.png").text
    assert _named(speeds["Title"]) == {(True, 0.3, 0.0811)}
    assert _named(speeds["Description"]) == {(False, 1.0, 0.079), (False, 0.3, 0.0811)}
    assert _named(Image.open(out / "mechanism.png").text["Title"]) == {(True, 0.3, 0.0811)}

    page = (out / "animation.html").read_text()
    title = re.search(r"<title>(.*?)</title>", page).group(1)
    assert _named(title) == {(True, 0.3, 0.0811)}
    payload = json.loads(re.search(r"const D = (\{.*?\});\n", page).group(1))
    assert _named("; ".join(o["label"] for o in payload["outputs"])) == \
        {(False, 1.0, 0.079), (False, 0.3, 0.0811)}

    import ezdxf

    assert run_main(["export", problem, "--out", out, "--format", "dxf"])[0] == 0
    doc = ezdxf.readfile(out / "linkage.dxf")
    props = "; ".join(f"{k} = {v}" for k, v in doc.header.custom_vars)
    assert _named(props) == expected
    texts = "; ".join(e.dxf.text for e in doc.modelspace().query("TEXT"))
    assert _named(texts) == expected

    code, table = run_main(["compare", out / "design.yaml", ROOT / "problems" / "sharkov2022.yaml",
                            "--out", tmp_path / "compare"])
    assert code == 0
    rows = (tmp_path / "compare" / "compare.csv").read_text()
    assert ripple_label("midrange", 0.3, (1.0, 0.3)) in rows
    first = next(line for line in rows.splitlines()[1:] if "design.yaml" in line)
    assert "0.08109724" in first


def test_the_notebook_names_the_same_delta_as_the_other_outputs(tmp_path, monkeypatch):
    """notebooks/design_space.ipynb on the spreader's front at n = 8 (its ratio band makes the
    front one point, the solve's optimum: δ falls as the ratio rises to its cap 0.42) prints
    the picked design's δ in the same words and numbers as the outputs above."""
    from optdesign.fronts import sweep
    from optdesign.problem.loader import load_problem

    data = yaml.safe_load((ROOT / "problems" / "spreader.yaml").read_text())
    data["design"]["phases"] = 8
    data["pareto"] = {"points": 2, "refine": {"enabled": False}}
    data["solver"] = {"screen": 64, "starts": 2, "basins": 1}
    problem = tmp_path / "spreader.yaml"
    problem.write_text(yaml.safe_dump(data))
    sweep(load_problem(problem), tmp_path / "front", workers=1, progress=False)

    def point_at_it(nb):
        inputs = next(c for c in nb.cells if c.cell_type == "code")
        inputs.source = f"PROBLEM = {str(problem)!r}\nFRONT = {str(tmp_path / 'front')!r}"

    _, outputs = executed_notebook("design_space.ipynb", monkeypatch, point_at_it)
    assert not [o for o in outputs if o.get("output_type") == "error"]
    text = "".join(o.get("text", "") for o in outputs)
    picked = "\n".join(line for line in text.splitlines()
                       if line.startswith(("n = 8,", "δ at each:")))
    assert _named(picked) == {(True, 0.3, 0.0811), (False, 1.0, 0.079), (False, 0.3, 0.0811)}
    assert "(front says 0.0811)" in picked

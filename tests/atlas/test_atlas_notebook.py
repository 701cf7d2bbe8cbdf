"""notebooks/design_atlas.ipynb runs top to bottom on the shipped atlas and answers the
concept questions with the atlas's own numbers."""
import pandas as pd

from tests.conftest import ROOT, executed_notebook

SHIPPED = ROOT / "benchmarks" / "results" / "atlas_fourbar" / "atlas.csv"


def test_the_design_atlas_notebook_answers_from_the_shipped_atlas(monkeypatch):
    _, outputs = executed_notebook("design_atlas.ipynb", monkeypatch)
    assert not [o for o in outputs if o.get("output_type") == "error"]
    text = "".join(o.get("text", "") for o in outputs)
    # the least count for δ <= 0.1 under 40 deg and ratio >= 0.5, read off the csv here
    atlas = pd.read_csv(SHIPPED)
    meets = atlas[(atlas["min_transmission_angle_deg"] == 40) & (atlas["min_ratio"] == 0.5)
                  & (atlas["status"] == "optimal") & (atlas["delta"] <= 0.1)]
    assert f"ratio ≥ 0.5: n = {meets['phases'].min()} " in text
    assert "a 45° rule instead of 40° adds" in text
    assert len([o for o in outputs if "image/png" in o.get("data", {})]) == 1


def test_the_notebook_runs_on_an_atlas_that_fixes_the_ratio_floor(monkeypatch, tmp_path):
    """atlas.csv leaves out what the atlas file fixes (here min_ratio): the notebook takes it
    from atlas.json beside it instead of raising KeyError, and prints plain numbers."""
    import json

    atlas = pd.read_csv(SHIPPED)
    atlas[atlas["min_ratio"] == 0.5].drop(columns="min_ratio").to_csv(tmp_path / "atlas.csv",
                                                                      index=False)
    doc = json.loads((SHIPPED.parent / "atlas.json").read_text())
    doc["fixed"] = doc["fixed"] | {"min_ratio": 0.5}
    (tmp_path / "atlas.json").write_text(json.dumps({"fixed": doc["fixed"]}))

    def point_at_it(nb):
        inputs = next(c for c in nb.cells if c.cell_type == "code")
        inputs.source = inputs.source.replace(
            'ATLAS = "../benchmarks/results/atlas_fourbar/atlas.csv"',
            f"ATLAS = {str(tmp_path / 'atlas.csv')!r}")
        assert str(tmp_path) in inputs.source

    _, outputs = executed_notebook("design_atlas.ipynb", monkeypatch, point_at_it)
    assert not [o for o in outputs if o.get("output_type") == "error"]
    text = "".join(o.get("text", "") for o in outputs)
    assert "ratio floor [0.5]" in text and "np." not in text
    assert "ratio ≥ 0.5: n = " in text


def test_the_notebook_runs_on_an_atlas_that_fixes_the_rule(monkeypatch, tmp_path):
    """An atlas file that fixes the transmission-angle rule has one rule: the least count is
    read at it, and the stricter rule's price is said to be out of the atlas, not a
    KeyError."""
    import json

    atlas = pd.read_csv(SHIPPED)
    atlas[atlas["min_transmission_angle_deg"] == 40].drop(
        columns="min_transmission_angle_deg").to_csv(tmp_path / "atlas.csv", index=False)
    doc = json.loads((SHIPPED.parent / "atlas.json").read_text())
    (tmp_path / "atlas.json").write_text(json.dumps(
        {"fixed": doc["fixed"] | {"min_transmission_angle_deg": 40.0}}))

    def point_at_it(nb):
        inputs = next(c for c in nb.cells if c.cell_type == "code")
        inputs.source = inputs.source.replace(
            'ATLAS = "../benchmarks/results/atlas_fourbar/atlas.csv"',
            f"ATLAS = {str(tmp_path / 'atlas.csv')!r}")

    _, outputs = executed_notebook("design_atlas.ipynb", monkeypatch, point_at_it)
    assert not [o for o in outputs if o.get("output_type") == "error"]
    text = "".join(o.get("text", "") for o in outputs)
    assert "rule [40.0] deg" in text and "np." not in text
    meets = atlas[(atlas["min_transmission_angle_deg"] == 40) & (atlas["min_ratio"] == 0.5)
                  & (atlas["status"] == "optimal") & (atlas["delta"] <= 0.1)]
    assert f"ratio ≥ 0.5: n = {meets['phases'].min()} " in text
    assert "a 45° rule cannot be priced from it" in text

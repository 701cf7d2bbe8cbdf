"""notebooks/design_space.ipynb runs top to bottom on the small front (no network needed)."""
import json

from tests.conftest import executed_notebook


def test_design_space_notebook_executes(small_front, small_path, monkeypatch):
    def point_at_the_small_front(nb):
        inputs = next(c for c in nb.cells if c.cell_type == "code")
        assert "PROBLEM =" in inputs.source and "FRONT =" in inputs.source
        inputs.source = f"PROBLEM = {str(small_path)!r}\nFRONT = {str(small_front[1])!r}"
    nb, outputs = executed_notebook("design_space.ipynb", monkeypatch, point_at_the_small_front)
    assert not [o for o in outputs if o.get("output_type") == "error"]
    text = "".join(o.get("text", "") for o in outputs)
    assert "non-dominated designs, hypervolume" in text and "feasible: True" in text
    images = [o for o in outputs if "image/png" in o.get("data", {})]
    assert len(images) == 4             # fronts, lengths, speeds, mechanism: each once
    tables = [o for o in outputs if "text/html" in o.get("data", {})]
    assert any("non-dominated designs" in o["data"]["text/html"] for o in tables)
    source = "".join(c.source for c in nb.cells if c.cell_type == "code")
    imports = {line.split()[1] for line in source.splitlines()
               if line.startswith(("from optdesign", "import optdesign"))}
    assert imports == {"optdesign"}     # the public API only
    # the last cell: the picked design in the live explorer, a Panel widget with its δ
    widgets = [o for o in outputs if "application/vnd.holoviews_exec.v0+json" in o.get("data", {})]
    assert widgets and "explore-delta" in json.dumps(outputs)

"""notebooks/design_space.ipynb runs top to bottom on small fronts (no network needed): the
small four-bar front, a housing front with two eccentricities, and a shipped front of another
mechanism (the slotted lever's sections)."""
import json

import pytest
import yaml

from tests.conftest import ROOT, executed_notebook
from tests.pareto.conftest import small


def _pointed_at(problem, front, title_after=True):
    """An edit: the notebook's inputs replaced by ``problem`` and ``front``; with
    ``title_after``, a cell after the fronts' figure prints its title."""
    def edit(nb):
        import nbformat

        inputs = next(c for c in nb.cells if c.cell_type == "code")
        assert "PROBLEM =" in inputs.source and "FRONT =" in inputs.source
        inputs.source = f"PROBLEM = {str(problem)!r}\nFRONT = {str(front)!r}"
        if title_after:
            at = next(i for i, c in enumerate(nb.cells) if "plot_front(" in c.source)
            nb.cells.insert(at + 1, nbformat.v4.new_code_cell(
                'print("front title:", fig.axes[0].get_title())'))
    return edit


def _text(outputs) -> str:
    assert not [o for o in outputs if o.get("output_type") == "error"]
    return "".join(o.get("text", "") for o in outputs)


def test_design_space_notebook_executes(small_front, small_path, monkeypatch):
    nb, outputs = executed_notebook("design_space.ipynb", monkeypatch,
                                    _pointed_at(small_path, small_front[1], False))
    text = _text(outputs)
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


@pytest.fixture(scope="module")
def housing_front(tmp_path_factory):
    """(problem path, front folder) of the small problem swept against the housing radius,
    its δ the worst over e = 1 and 0.5."""
    from optdesign.fronts import sweep
    from optdesign.problem.loader import load_problem

    data = small(points=3, against="housing_radius")
    data["regulation"] = {"eccentricity": [1.0, 0.5]}
    folder = tmp_path_factory.mktemp("housing_front")
    path = folder / "small_housing.yaml"
    path.write_text(yaml.safe_dump(data))
    sweep(load_problem(path), folder / "front", workers=1, progress=False)
    return path, folder / "front"


def test_the_notebook_follows_a_housing_front_with_two_eccentricities(housing_front,
                                                                      monkeypatch):
    """Titled by its axis, the pick the least housing radius within the ripple allowance,
    its δ the worst over both eccentricities (as the front's), and plain numbers printed."""
    path, front = housing_front
    _, outputs = executed_notebook("design_space.ipynb", monkeypatch, _pointed_at(path, front))
    text = _text(outputs)
    assert "front title: small_front: δ against housing radius" in text
    assert "against ratio" not in text and "np." not in text
    assert "δ (midrange) against housing radius, 1 count(s) [4], eccentricities [1.0, 0.5]" \
        in text
    pick = next(line for line in text.splitlines() if line.startswith("n = 4, housing radius"))
    assert "worst over e = 1, 0.5, at e = " in pick and "feasible: True" in pick
    assert "δ at each: δ (midrange, at e = 1) = " in text and "(midrange, at e = 0.5)" in text
    from optdesign import load_problem, pareto

    ok = pareto(load_problem(path), out=front, resume=True).to_frame().query(
        "status == 'optimal'")
    least = ok[ok["delta"] <= 1.5 * ok["delta"].min()]["housing_radius"].min()
    assert f"housing radius {least:.4f}," in pick


def test_the_notebook_runs_on_the_shipped_slotted_lever_front(tmp_path, monkeypatch):
    """Another mechanism: its count is `sections`, one free length, one listed e."""
    from optdesign.fronts import sweep
    from optdesign.problem.loader import load_problem

    data = yaml.safe_load((ROOT / "problems" / "pareto_slotted_forward.yaml").read_text())
    data["pareto"] |= {"points": 3, "refine": {"enabled": False}}
    data["solver"] |= {"starts": 2}
    path = tmp_path / "slotted.yaml"
    path.write_text(yaml.safe_dump(data))
    sweep(load_problem(path), tmp_path / "front", workers=1, progress=False)
    _, outputs = executed_notebook("design_space.ipynb", monkeypatch,
                                   _pointed_at(path, tmp_path / "front"))
    text = _text(outputs)
    assert "front title: pareto_slotted_forward: δ against ratio" in text
    assert "feasible: True" in text and "np." not in text



def test_the_knees_design_is_what_the_plots_and_analyze_take(small_front, small_path):
    """``front.knee`` is the knee's whole row (every column of pareto.csv), which a design
    argument refuses; ``front.knee_design`` is its design alone, the lengths and the count
    (the API's own example plotted the row, and raised)."""
    import matplotlib.pyplot as plt

    from optdesign import analyze, load_problem, plot_speeds
    from optdesign.errors import ProblemError

    problem, result = load_problem(small_path), small_front[0]
    with pytest.raises(ProblemError, match="design.delta is not a known key"):
        plot_speeds(problem, result.knee.to_dict())
    design = result.knee_design
    assert set(design) == set(problem.design)
    assert design == result.design_of(result.knee.name) == result.design_of(result.knee)
    assert design[problem.model.count_variable] == int(result.knee["phases"])
    assert all(design[k] == result.knee[k] for k in problem.model.lengths)
    checked = analyze(problem, design)
    assert checked.to_frame()["delta"].max() == pytest.approx(result.knee["delta"], rel=1e-6)
    plt.close(plot_speeds(problem, design))

"""A front against another quantity than the ratio (``pareto: {against: QUANTITY}``): the least
ripple against the housing radius, every point verified exactly and holding its bound, the
front non-dominated in (δ, housing radius), a resumed sweep the same front."""
import math

import numpy as np
import pandas as pd
import pytest
import yaml

from optdesign.cli import main
from optdesign.errors import ProblemError
from optdesign.fronts import sweep
from optdesign.problem.loader import load_problem, problem_from_dict
from optdesign.quantities import design_quantities
from optdesign.solver import verify
from tests.conftest import ROOT

from .conftest import small


def _housing(points=4, **pareto):
    data = small(points=points)
    data["pareto"] |= {"against": "housing_radius"} | pareto
    return data


@pytest.fixture(scope="module")
def housing_front(tmp_path_factory):
    path = tmp_path_factory.mktemp("against") / "housing.yaml"
    path.write_text(yaml.safe_dump(_housing()))
    out = tmp_path_factory.mktemp("housing_out")
    problem = load_problem(path)
    return problem, sweep(problem, out, workers=1, progress=False), out, path


def test_every_point_holds_its_casing_and_is_verified_exactly(housing_front):
    problem, result, _, _ = housing_front
    ok = result.points[result.points["status"] == "optimal"]
    assert len(ok) >= 3
    for _, row in ok.iterrows():
        design = {k: row[k] for k in problem.model.lengths} | {"phases": int(row["phases"])}
        ver = verify(problem, design)
        assert ver.feasible
        assert ver.delta == pytest.approx(row["delta"], abs=1e-12)
        radius = design_quantities(problem, ver.evaluation)["values"]["housing_radius"]
        assert radius == pytest.approx(row["housing_radius"], rel=1e-12)
        # the ε of a sweep point is the casing it was solved in (mm): held to the check's
        # tolerance
        if row["kind"] == "sweep":
            assert radius <= row["epsilon"] * (1 + 1e-7)
    # the casing is the trade: a smaller casing costs ripple along the front
    front = result.front
    assert list(front["housing_radius"]) == sorted(front["housing_radius"])
    assert np.all(np.diff(front["delta"].to_numpy()) <= 1e-9)
    assert front["housing_radius"].iloc[0] < front["housing_radius"].iloc[-1] - 1.0


def test_the_ends_are_the_least_ripple_and_the_least_casing(housing_front):
    problem, result, _, _ = housing_front
    ends = {e["kind"]: e for e in result.ends}
    assert set(ends) == {"least_ripple", "best_housing_radius"}
    least = ends["least_ripple"]
    smallest = ends["best_housing_radius"]
    assert smallest["housing_radius"] < least["housing_radius"]
    assert smallest["delta"] >= least["delta"]
    # no point of the front has a smaller casing than the least-casing end
    ok = result.points[result.points["status"] == "optimal"]
    assert ok["housing_radius"].min() >= smallest["housing_radius"] * (1 - 1e-7)


def test_the_files_name_the_quantity_and_its_unit(housing_front):
    _, result, out, _ = housing_front
    doc = result.to_dict()
    assert doc["run"]["against"] == "housing_radius"
    assert doc["units"]["epsilon"].startswith("mm")
    assert set(doc["indicators"]["ideal"]) == {"delta", "housing_radius"}
    csv = pd.read_csv(out / "pareto.csv")
    assert {"housing_radius", "epsilon", "delta", "ratio"} <= set(csv.columns)


def test_a_resumed_sweep_gives_the_same_front(housing_front, tmp_path):
    problem, result, out, path = housing_front
    copy = tmp_path / "again"
    copy.mkdir()
    lines = (out / "points.jsonl").read_text().splitlines()
    (copy / "points.jsonl").write_text("\n".join(lines[:len(lines) // 2]) + "\n")
    again = sweep(problem, copy, workers=1, resume=True, progress=False)
    cols = ["phases", "delta", "housing_radius", "epsilon"]
    pd.testing.assert_frame_equal(again.points[cols].reset_index(drop=True),
                                  result.points[cols].reset_index(drop=True))


@pytest.mark.parametrize("change,message", [
    ({"against": "ripple"}, r"pareto\.against must be one of ratio, housing_radius"),
    ({"ratio_lower": 0.5}, r"pareto\.ratio_lower bounds the ratio's sweep"),
])
def test_bad_against_is_named(change, message):
    with pytest.raises(ProblemError, match=message):
        problem_from_dict(_housing(**change), where="p.yaml")


def test_the_shipped_front_against_the_casing_is_a_file_of_its_own(tmp_path, capsys):
    """problems/pareto_housing.yaml sweeps: a quick run of it (few points, no rounds)."""
    data = yaml.safe_load((ROOT / "problems" / "pareto_housing.yaml").read_text())
    data["pareto"] = {"against": "housing_radius", "points": 3, "refine": {"enabled": False}}
    path = tmp_path / "p.yaml"
    path.write_text(yaml.safe_dump(data))
    assert main(["pareto", str(path), "--out", str(tmp_path / "o"), "--workers", "1",
                 "--no-report"]) == 0
    out = capsys.readouterr().out
    assert "housing_radius =" in out
    csv = pd.read_csv(tmp_path / "o" / "pareto.csv")
    ok = csv[csv["status"] == "optimal"]
    # the disc problem's least ripple sweeps l1 + l2 = 420 mm (docs/quantities.md)
    assert ok["housing_radius"].max() == pytest.approx(420, rel=1e-7)
    assert math.isclose(ok["delta"].min(), 0.1402049196, abs_tol=1e-9)

"""A front's table names the count as its mechanism does, and its criteria's columns are the
problem's own: the four-bar keeps ``phases`` and its ``pin_radius``, the slotted lever has
``sections``, the generic ``count`` and, for one release, the deprecated ``phases``."""
import csv
import json

import yaml

from tests.conftest import ROOT


def test_the_four_bar_front_keeps_phases_first_and_its_pin_radius(small_front):
    result, out = small_front
    with open(out / "pareto.csv", newline="") as f:
        header = next(csv.reader(f))
    assert header[:3] == ["phases", "delta", "ratio"] and "count" in header
    assert "pin_radius" in header and header.count("phases") == 1
    data = json.loads((out / "pareto.json").read_text())
    assert data["units"]["pin_radius"].startswith("mm (|AC_i|: l2 - l2_prime")
    assert data["units"]["count"] == data["units"]["phases"] == "- (count)"
    assert all(p["count"] == p["phases"] for p in data["points"])


def test_a_slotted_lever_front_names_its_sections(tmp_path):
    from optdesign import pareto

    data = yaml.safe_load((ROOT / "problems" / "vergov_solve.yaml").read_text())
    data["design"]["sections"] = 3
    data["pareto"] = {"points": 3, "refine": {"enabled": False}}
    front = pareto(data, out=tmp_path / "lever")
    columns = list(front.points.columns)
    assert columns[0] == "sections" and {"count", "phases"} <= set(columns)
    assert "pin_radius" not in columns                 # a four-bar column, not the lever's
    assert (front.points["sections"] == front.points["count"]).all()
    written = json.loads((tmp_path / "lever" / "pareto.json").read_text())
    assert written["units"]["sections"] == "- (count)" and "pin_radius" not in written["units"]

"""``objective: {minimize: phases}``: the least count whose least δ meets the ripple cap, held
against the shipped atlas's answer for the same rule (the same mechanism, box, transmission
angle, pin radius and ratio floor), and the bad inputs refused in one line."""
import json

import pandas as pd
import pytest
import yaml

from optdesign.atlas.spec import load_atlas
from tests.conftest import ROOT, run_main

ATLAS = ROOT / "benchmarks" / "results" / "atlas_fourbar"
RULE_DEG, RATIO_FLOOR, TARGET = 40.0, 0.5, 0.2


def _atlas_rule_problem(tmp_path, target: float, counts=(3, 12), name="rule") -> "Path":
    """The atlas file's cell problem at RULE_DEG and RATIO_FLOOR, every count of ``counts``
    admissible, asked for the least count with δ <= ``target``."""
    spec = load_atlas(ROOT / "problems" / "atlas_fourbar.yaml")
    design = {k: v for k, v in spec.base["design"].items() if k != "phases"}
    data = {"name": name, "mechanism": spec.mechanism, "input_speed": 1.0,
            "stroke": spec.fixed["stroke"],
            "design": design | {"phases": {"lower": counts[0], "upper": counts[1]}},
            "constraints": {"min_transmission_angle_deg": RULE_DEG,
                            "min_pin_radius": spec.fixed["min_pin_radius"],
                            "ripple": {"upper": target}},
            "objective": dict(spec.base["objective"]) | {"minimize": "phases",
                                                         "min_ratio": RATIO_FLOOR}}
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_the_least_count_is_the_atlas_answer_for_the_same_rule(tmp_path):
    atlas = pd.read_csv(ATLAS / "atlas.csv")
    rule = atlas[(atlas["min_transmission_angle_deg"] == RULE_DEG)
                 & (atlas["min_ratio"] == RATIO_FLOOR) & (atlas["status"] == "optimal")]
    answer = int(rule[rule["delta"] <= TARGET]["phases"].min())
    assert answer > 3                   # counts below it to explain: the test can tell

    out = tmp_path / "solved"
    code, _ = run_main(["solve", _atlas_rule_problem(tmp_path, TARGET), "--out", out,
                        "--json", "--no-plots"])
    assert code == 0
    result = json.loads((out / "result.json").read_text())
    least = result["least_count"]
    assert result["status"] == "optimal" and least["count"] == answer
    assert result["design"]["phases"] == answer
    assert least["key"] == "constraints.ripple.upper" and least["bound"] == TARGET
    assert least["not_solved"] == list(range(answer + 1, 13)) and least["unsettled"] == []
    # each count's least δ is the atlas cell's (both verified exactly; the same screening
    # and polish, so 1e-6 relative leaves room only for IPOPT's tolerance)
    by_count = rule.set_index("phases")["delta"]
    assert [r["count"] for r in least["counts"]] == list(range(3, answer + 1))
    for row in least["counts"]:
        assert row["delta"] == pytest.approx(by_count[row["count"]], rel=1e-6)
        assert row["meets"] == (row["count"] == answer)
    below = [p for p in result["per_phase"] if p["count"] < answer]
    assert all(p["status"] == "infeasible" and p["reachable"]["constraint"] == "max_ripple"
               and p["reachable"]["value"] > TARGET for p in below)
    assert result["delta"] == pytest.approx(by_count[answer], rel=1e-6)
    assert result["delta"] <= TARGET


def test_no_count_meets_a_bound_below_every_least_delta(tmp_path):
    """Exit 1, status infeasible, and every count's least δ shown (why each fails)."""
    path = _atlas_rule_problem(tmp_path, 0.1, counts=(3, 4), name="tight")
    code, text = run_main(["solve", path, "--out", tmp_path / "o", "--no-plots"])
    assert code == 1
    assert "least count for δ ≤ 0.1 (constraints.ripple.upper): none of the admissible " \
           "phases meets it" in text
    assert "n = 3: 0.449879 > 0.1; n = 4: 0.252056 > 0.1" in text
    result = json.loads((tmp_path / "o" / "result.json").read_text())
    assert result["status"] == "infeasible" and result["least_count"]["count"] is None
    assert "the least δ any of them reaches is 0.252056, with 4 phases" in result["message"]


def test_the_design_yaml_of_a_least_count_runs_as_it_is(tmp_path):
    """The count is fixed in design.yaml: its objective becomes the count's own (the least
    δ), so the file loads and its design meets every constraint."""
    out = tmp_path / "solved"
    assert run_main(["solve", _atlas_rule_problem(tmp_path, 0.3, counts=(3, 5)), "--out", out,
                     "--no-plots"])[0] == 0
    assert yaml.safe_load((out / "design.yaml").read_text())["objective"]["minimize"] == \
        "ripple"
    assert run_main(["analyze", out / "design.yaml"])[0] == 0


@pytest.mark.parametrize("edit, key", [
    (lambda d: d["constraints"].pop("ripple"), "objective.max_ripple is required when "
                                               "minimize is phases (or constraints.ripple.upper)"),
    (lambda d: d["design"].update(phases=6), "design.phases is fixed at 6: minimize: phases"),
    (lambda d: d["design"].update(phases={"choices": [5]}), "design.phases is fixed at 5"),
    (lambda d: d["objective"].update(max_ripple=0.2), "constraints.ripple.upper and "
                                                      "objective.max_ripple name the same bound"),
])
def test_bad_least_count_input_is_one_line_naming_the_key(tmp_path, capsys, edit, key):
    path = _atlas_rule_problem(tmp_path, TARGET)
    data = yaml.safe_load(path.read_text())
    edit(data)
    path.write_text(yaml.safe_dump(data))
    code, _ = run_main(["solve", path, "--out", tmp_path / "o"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1
    assert err.startswith(f"optdesign: {path.name}: ") and key in err


def test_the_api_and_the_schema_know_the_least_count(tmp_path):
    from optdesign import load_problem, solve
    from optdesign.problem.schema import problem_schema

    result = solve(load_problem(_atlas_rule_problem(tmp_path, 0.3, counts=(3, 5))))
    assert result.least_count["count"] == 4 and result.fun == 4.0
    assert "least count 4 for δ ≤ 0.3" in result.summary()
    schema = problem_schema()
    minimize = schema["properties"]["objective"]["properties"]["minimize"]
    assert "phases" in minimize["enum"]
    rule = next(r["then"] for r in schema["allOf"] if r["if"]["properties"].get(
        "objective", {}).get("properties", {}).get("minimize") == {"const": "phases"})
    assert rule["anyOf"][0] == {"properties": {"objective": {"required": ["max_ripple"]}},
                                "required": ["objective"]}
    assert rule["anyOf"][1]["properties"]["constraints"]["properties"] == \
        {"ripple": {"required": ["upper"]}}

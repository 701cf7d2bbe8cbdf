"""Words and units of the outputs: every JSON document a command writes carries
``schema_version`` and names the unit of every number it holds; the midrange is
``omega_midrange`` (``omega_avg`` its deprecated alias); the ratio's convention is stated and the
gear ratio i = 1/ratio printed beside it."""
import csv
import io
import json
import re
from numbers import Number

import pytest
import yaml

from optdesign.cli import main
from optdesign.outputs.atomic import SCHEMA_VERSION
from optdesign.outputs.units import OPAQUE, gear_ratio_text, units_of
from tests.conftest import ROOT, run_main
from tests.pareto.conftest import SMALL

PROBLEMS = ROOT / "problems"


run = run_main


@pytest.fixture(scope="module")
def outputs(tmp_path_factory):
    """Every JSON document the commands write or print, by name, and the solve's summary."""
    tmp = tmp_path_factory.mktemp("units")
    small = tmp / "small_front.yaml"
    small.write_text(yaml.safe_dump(SMALL | {"pareto": {"points": 2}}))
    docs, texts = {}, {}
    for name in ("driveline", "vergov", "pulse_reducer"):
        code, out = run(["analyze", PROBLEMS / f"{name}.yaml", "--json"])
        assert code == 0
        docs[f"analyze {name}"] = json.loads(out)
    code, out = run(["solve", small, "--json", "--no-plots", "--out", tmp / "solve"])
    assert code == 0
    docs["solve --json"] = json.loads(out)
    docs["result.json"] = json.loads((tmp / "solve" / "result.json").read_text())
    texts["summary.txt"] = (tmp / "solve" / "summary.txt").read_text()
    assert run(["pareto", small, "--out", tmp / "pareto", "--workers", 1, "--no-report"])[0] == 0
    docs["pareto.json"] = json.loads((tmp / "pareto" / "pareto.json").read_text())
    texts["pareto.csv"] = (tmp / "pareto" / "pareto.csv").read_text()
    code, out = run(["driveline", PROBLEMS / "driveline.yaml", "--json", "--out", tmp / "dl"])
    assert code == 0
    docs["driveline --json"] = json.loads(out)
    code, out = run(["simulate", PROBLEMS / "sharkov2022_dynamics.yaml", "--json", "--out",
                     tmp / "sim"])
    assert code in (0, 1)
    docs["simulate --json"] = json.loads(out)
    docs["dynamics.json"] = json.loads((tmp / "sim" / "dynamics.json").read_text())
    return docs, texts


def unlisted(document: dict) -> set[str]:
    """Keys holding a number (at any depth) that ``units`` does not name, itself or through
    an enclosing block of one unit (``timings_s``)."""
    units, missing = document["units"], set()

    def walk(value, key, covered):
        if isinstance(value, dict):
            for k, v in value.items():
                walk(v, k, covered or (key in OPAQUE and key in units))
        elif isinstance(value, list):
            for v in value:
                walk(v, key, covered)
        elif isinstance(value, Number) and not isinstance(value, bool):
            if not covered and key not in units:
                missing.add(key)

    for key, value in document.items():
        if key != "units":
            walk(value, key, False)
    return missing


DOCUMENTS = ["analyze driveline", "analyze vergov", "analyze pulse_reducer", "solve --json",
             "result.json", "pareto.json", "driveline --json", "simulate --json",
             "dynamics.json"]


def test_schema_version_is_one_dotted_string():
    assert re.fullmatch(r"\d+\.\d+", SCHEMA_VERSION)


@pytest.mark.parametrize("name", DOCUMENTS)
def test_every_number_has_its_unit(outputs, name):
    doc = outputs[0][name]
    assert doc["schema_version"] == SCHEMA_VERSION
    assert list(doc)[-2:] == ["schema_version", "units"]          # after the contract's keys
    assert unlisted(doc) == set()
    # a unit is named only for a key the document holds
    assert set(doc["units"]) <= _keys(doc)


def _keys(value) -> set:
    if isinstance(value, dict):
        return set(value) | {k for v in value.values() for k in _keys(v)}
    if isinstance(value, list):
        return {k for v in value for k in _keys(v)}
    return set()


def test_units_of_the_main_figures(outputs):
    units = outputs[0]["analyze driveline"]["units"]
    assert units["omega_midrange"].startswith("rad/s")
    assert units["omega_max"] == units["omega_min"] == "rad/s"
    assert units["l0"] == units["l3"] == "mm" and units["phases"] == "-"
    assert units["design"] == "mm (lengths), - (counts)"
    assert units["min_transmission_angle_deg"] == "deg"
    assert units["critical_speed_rad_s"] == "rad/s" and units["D0_g_mm"] == "g*mm"
    assert "output speed / input speed" in units["ratio"] and "i = 1/ratio" in units["ratio"]
    assert outputs[0]["result.json"]["units"]["timings_s"].startswith("s")
    assert outputs[0]["analyze vergov"]["units"]["XD"] == "mm"


def test_pareto_csv_columns_have_their_units_in_pareto_json(outputs):
    docs, texts = outputs
    rows = list(csv.DictReader(io.StringIO(texts["pareto.csv"])))
    assert rows
    numeric = {k for k, v in rows[0].items() if re.fullmatch(r"-?[\d.]+(e[-+]?\d+)?", v or "")}
    assert {"delta", "ratio", "l1", "l3", "phases"} <= numeric
    assert numeric <= set(docs["pareto.json"]["units"])


def test_midrange_is_named_so_and_its_old_name_stays_one_release(outputs):
    doc = outputs[0]["analyze driveline"]
    every = list(doc["strokes"].values()) + [f for r in doc["regulation"]
                                            for f in r["strokes"].values()]
    for f in every:
        assert f["omega_midrange"] == f["omega_avg"] == \
            pytest.approx(0.5 * (f["omega_max"] + f["omega_min"]), rel=1e-15)
        assert f["omega_midrange"] != f["omega_mean"]
    assert "deprecated" in doc["units"]["omega_avg"]
    for r in outputs[0]["solve --json"]["per_phase"][0]["regulation"]:
        assert r["omega_avg"] == r["omega_midrange"]


def test_the_old_attribute_warns():
    from optdesign.envelope.sampled import StrokeFigures

    f = StrokeFigures.from_extremes(3.0, 1.0, 2.1, 10.0)
    assert f.omega_midrange == 2.0 and f.delta == 1.0
    with pytest.warns(DeprecationWarning, match="omega_midrange"):
        assert f.omega_avg == 2.0


def test_terminal_table_says_mid_mm_and_the_gear_ratio(capsys):
    assert main(["analyze", str(PROBLEMS / "sharkov2022.yaml")]) == 0
    out = capsys.readouterr().out
    assert "ω_mid" in out and "ω_avg" not in out
    assert "l0 = 225 mm" in out and "phases = 6," not in out and "phases = 6\n" in out
    # the paper's forward stroke: ratio 0.344296, i = 1/0.344296 = 2.90448
    assert re.search(r"forward .* 0\.3443 +2\.9045\n", out)
    assert "gear ratio i = n_in/n_out is 1/ratio" in out


def test_solve_summary_prints_the_gear_ratio(outputs):
    docs, texts = outputs
    ratio = docs["result.json"]["ratio"]
    assert f"ratio = {ratio:.6f} (output/input speed; gear ratio i = 1/ratio = " \
           f"{1 / ratio:.4f})" in texts["summary.txt"]


def test_gear_ratio_text():
    assert gear_ratio_text(0.25) == "4.0000"
    assert gear_ratio_text(0.0) == "inf"            # an output at rest
    assert gear_ratio_text(None) == gear_ratio_text(float("nan")) == "-"


def test_units_of_reads_variables_names_and_suffixes_and_skips_the_unknown():
    doc = {"design": {"l0": 1.0, "phases": 4}, "speed_limit_rad_s": 2.0, "what": 3.0,
           "timings_s": {"build": 0.1}, "text_only": "x", "chains_min_transmission_angle_deg":
           [40.0], "rows": [{"time_s": 1.0}], "flag": True, "binding": None}
    units = units_of(doc, {"l0": "mm", "phases": "-"})
    assert units == {"chains_min_transmission_angle_deg": "deg",
                     "design": "mm (lengths), - (counts)", "l0": "mm", "phases": "-",
                     "speed_limit_rad_s": "rad/s", "time_s": "s",
                     "timings_s": "s (per stage)"}          # "what": unknown, left out

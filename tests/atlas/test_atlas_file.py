"""A bad atlas file: exit 2 and one line naming the file and the key, never a traceback."""
import copy

import pytest
import yaml

from optdesign.cli import main
from tests.atlas.conftest import TINY


def _with(change):
    data = copy.deepcopy(TINY)
    change(data)
    return data


CASES = [
    (lambda d: d.update(colour="red"), "tiny.yaml: colour is not a known key"),
    (lambda d: d["axes"].update(phase=[3]), "tiny.yaml: axes.phase is not a known key; did "
                                             "you mean phases?"),
    (lambda d: d.update(mechanism="slotted_lever"), "tiny.yaml: mechanism an atlas supports "
                                                   "fourbar_converter only"),
    (lambda d: d["axes"].update(min_ratio={"lower": 0.3, "upper": 0.6, "step": 0}),
     "tiny.yaml: axes.min_ratio.step must be positive (got 0)"),
    (lambda d: d["fixed"].update(phases=6), "tiny.yaml: fixed.phases is an axis too"),
    (lambda d: d["design"].update(l1=20), "tiny.yaml: design.l1 is the length every other is "
                                          "relative to"),
    (lambda d: d["design"]["l3"].update(upper=0.5), "tiny.yaml: design.l3.upper must not be "
                                                    "below lower"),
    (lambda d: d.update(objective={"minimize": "-ratio"}), "tiny.yaml: objective.minimize an "
                                                          "atlas maps the least ripple"),
    (lambda d: d["axes"].update(stroke={"lower": 1, "upper": 2, "step": 1}),
     "tiny.yaml: axes.stroke must be a list of values"),
    (lambda d: d["axes"].update(phases={"lower": 3, "upper": 5, "step": 0.5}),
     "tiny.yaml: axes.phases.step must be a whole number: the count takes whole values "
     "(got 0.5)"),
]


@pytest.mark.parametrize("change, message", CASES, ids=range(len(CASES)))
def test_a_bad_atlas_file_is_one_line_and_exit_2(tmp_path, capsys, change, message):
    path = tmp_path / "tiny.yaml"
    path.write_text(yaml.safe_dump(_with(change)))
    assert main(["atlas", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith(f"optdesign: {message}"), err
    assert not (tmp_path / "out" / "cells.jsonl").exists()


def test_resume_without_a_journal_says_so(tmp_path, capsys):
    path = tmp_path / "tiny.yaml"
    path.write_text(yaml.safe_dump(TINY))
    assert main(["atlas", str(path), "--out", str(tmp_path / "out"), "--resume"]) == 2
    assert "nothing to resume" in capsys.readouterr().err


def _copied(tiny_atlas, tmp_path):
    import shutil
    out = tmp_path / "out"
    shutil.copytree(tiny_atlas[0], out)
    return out


@pytest.mark.parametrize("data, ordered, changed", [
    (_with(lambda d: d["fixed"].update(min_ratio=0.4)), False, "atlas_sha256"),
    (TINY, True, "axes"),              # sorted: the axes in another order number the cells
])
def test_resume_refuses_a_journal_of_another_atlas(tiny_atlas, tmp_path, capsys, data,
                                                   ordered, changed):
    out = _copied(tiny_atlas, tmp_path)
    path = tmp_path / "tiny.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=ordered))
    assert main(["atlas", str(path), "--out", str(out), "--resume"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "cannot resume, the run's settings changed" in err
    assert f"({changed})" in err


def test_resume_refuses_a_record_that_is_not_its_designs(tiny_atlas, tmp_path, capsys):
    import json
    out = _copied(tiny_atlas, tmp_path)
    journal = out / "cells.jsonl"
    lines = journal.read_text().splitlines()
    record = json.loads(lines[2])
    record["delta"] *= 0.9                        # a better δ than its design has
    lines[2] = json.dumps(record)
    journal.write_text("\n".join(lines) + "\n")
    path = tmp_path / "tiny.yaml"
    path.write_text(yaml.safe_dump(TINY, sort_keys=False))
    assert main(["atlas", str(path), "--out", str(out), "--resume"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "cells.jsonl: line 3: the record does not match its " \
                                    "design" in err

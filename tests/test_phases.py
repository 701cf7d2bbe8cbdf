"""The phase clock: nothing recorded unless OPTDESIGN_PHASES names a file; then one JSON line
per command, its phases in order and the answer before the exit."""
import json
import os
import subprocess
import sys

from optdesign.outputs import phases
from tests.conftest import ROOT


def test_unset_nothing_is_recorded(monkeypatch):
    monkeypatch.delenv(phases.VARIABLE, raising=False)
    before = phases.record()["phases"]
    with phases.phase("reading"):
        pass
    phases.answered()
    assert phases.record()["phases"] == before and phases.record()["answer_s"] is None


def test_a_command_appends_one_line_of_its_phases(tmp_path):
    log = tmp_path / "phases.jsonl"
    log.write_text('{"an earlier": "line"}\n')
    env = os.environ | {"PYTHONPATH": str(ROOT), phases.VARIABLE: str(log)}
    done = subprocess.run([sys.executable, "-m", "optdesign", "analyze",
                           "problems/sharkov2022.yaml"], cwd=ROOT, env=env,
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    first, line = log.read_text().splitlines()
    assert json.loads(first) == {"an earlier": "line"}
    rec = json.loads(line)
    assert rec["argv"] == ["analyze", "problems/sharkov2022.yaml"]
    assert [p[0] for p in rec["phases"]] == ["imports", "reading", "evaluating"]
    ends = [t for p in rec["phases"] for t in p[1:]]
    assert ends == sorted(ends) and 0 < ends[0]                # one after another
    assert ends[-1] <= rec["answer_s"] <= rec["exit_s"]

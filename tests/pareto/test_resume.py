"""An interrupted sweep (the process killed) resumes without losing or recomputing a point."""
import os
import signal
import subprocess
import sys
import time

import pandas as pd
import yaml

from optdesign.cli import main
from optdesign.fronts.store import Journal
from tests.conftest import ROOT

from .conftest import small


def _records(path):
    return Journal(path).read()[1]


#: sweep points: enough that the kill, polled every few milliseconds, lands before the last
#: (at 4 phases a point's polish takes tens of milliseconds)
POINTS = 12


def test_killed_sweep_resumes_without_loss_or_recomputation(tmp_path):
    problem = tmp_path / "small.yaml"
    problem.write_text(yaml.safe_dump(small(points=POINTS)))
    out = tmp_path / "out"
    journal = out / "points.jsonl"
    env = os.environ | {"PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, "-m", "optdesign", "pareto", str(problem),
                             "--out", str(out), "--workers", "1", "--no-report"],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        # the two end solves and the end copies come first; kill once a sweep point is in
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline:
            if journal.exists() and any(r["kind"] == "sweep" for r in _records(journal)):
                break
            if proc.poll() is not None:
                break
            time.sleep(0.005)
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    before = _records(journal)
    keys_before = [tuple(r["key"]) for r in before]
    assert any(r["kind"] == "sweep" for r in before), "killed before any sweep point"
    assert len(keys_before) < 2 + POINTS, "the sweep finished before it could be killed"

    assert main(["pareto", str(problem), "--out", str(out), "--resume", "--workers", "1",
                 "--no-report"]) == 0
    after = _records(journal)
    keys_after = [tuple(r["key"]) for r in after]
    assert after[:len(before)] == before                      # nothing lost or rewritten
    assert len(set(keys_after)) == len(keys_after)            # nothing computed twice
    assert set(keys_after) == {(4, "least_ripple"), (4, "largest_ratio")} | {
        (4, i) for i in range(POINTS)}
    df = pd.read_csv(out / "pareto.csv")
    assert len(df) == POINTS and (df["status"] == "optimal").all()

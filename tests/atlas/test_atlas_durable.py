"""A killed atlas loses no finished cell: ``--resume`` finishes it to the same atlas, on local
processes, and a real two-worker Dask cluster finishes it when one worker is killed with
``kill -9`` while it solves a cell."""
import os
import signal
import subprocess
import sys
import time

import pandas as pd
import pytest

from optdesign.fronts.store import Journal
from tests.conftest import ROOT, run_main
from tests.pareto.test_cluster import cluster  # noqa: F401  (the two-worker cluster fixture)

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="kill -9")
ENV = os.environ | {"PYTHONPATH": str(ROOT)}


def _records(out):
    path = out / "cells.jsonl"
    return Journal(path).read()[1] if path.exists() else []


def _same_atlas(out, reference):
    """The two atlases' cells agree: status, and δ and ratio to 1e-6 (each cell is an
    optimum verified exactly; resumed or solved elsewhere, the same optimum)."""
    got = pd.read_csv(out / "atlas.csv")
    assert list(got["status"]) == list(reference["status"])
    assert got["delta"].to_numpy() == pytest.approx(reference["delta"].to_numpy(), rel=1e-6)
    assert got["ratio"].to_numpy() == pytest.approx(reference["ratio"].to_numpy(), rel=1e-6)


def test_a_killed_run_resumes_to_the_same_atlas(tiny_path, tiny_atlas, tmp_path):
    out = tmp_path / "out"
    run = subprocess.Popen([sys.executable, "-m", "optdesign", "atlas", str(tiny_path),
                            "--out", str(out), "--workers", "1", "--no-plots"], env=ENV,
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 120
    while not _records(out) and run.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    run.kill()
    run.wait(timeout=30)
    kept = len(_records(out))
    assert 1 <= kept < 4, "the run was not killed mid-atlas"
    code, stdout = run_main(["atlas", tiny_path, "--out", out, "--resume", "--workers", "1",
                             "--no-plots"])
    assert code == 0 and f"({kept} resumed)" in stdout
    records = _records(out)
    assert sorted(r["cell"] for r in records) == [0, 1, 2, 3]        # none solved twice
    _same_atlas(out, tiny_atlas[1])


def test_a_killed_dask_worker_loses_no_cell(cluster, tiny_path, tiny_atlas, tmp_path):
    from distributed import Client

    address, procs = cluster
    out = tmp_path / "out"
    with Client(address, timeout=30) as client:
        client.wait_for_workers(2, timeout=60)
        run = subprocess.Popen([sys.executable, "-m", "optdesign", "atlas", str(tiny_path),
                                "--out", str(out), "--scheduler", address, "--no-plots"],
                               env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True)
        victim, deadline = None, time.monotonic() + 120
        while victim is None and run.poll() is None and time.monotonic() < deadline:
            info = client.scheduler_info()["workers"]     # a worker may join in between
            busy = [info[w]["name"] for w, keys in client.processing().items()
                    if keys and w in info]
            if busy:            # a worker solving a cell: kill it
                victim = busy[0]
                os.kill(procs[victim].pid, signal.SIGKILL)
            time.sleep(0.02)
        stdout, stderr = run.communicate(timeout=180)
        assert victim is not None, "the atlas ended before a worker could be killed"
        assert run.returncode == 0, stderr
        assert procs[victim].wait(timeout=10) == -signal.SIGKILL
    assert sorted(r["cell"] for r in _records(out)) == [0, 1, 2, 3]
    _same_atlas(out, tiny_atlas[1])


@pytest.mark.parametrize("forged", [
    {"status": "infeasible", "feasible": False, "design": {}, "delta": None, "ratio": None},
    {"status": "garbage"},
], ids=["optimum said infeasible", "unknown status"])
def test_a_resumed_cell_that_is_not_a_feasible_optimum_is_solved_again(
        tiny_path, tiny_atlas, tmp_path, forged):
    """A verdict that no design was found cannot be checked without the solve, and a status
    that is none is no verdict: the cell is solved again, the atlas is the uninterrupted one."""
    import json

    done, reference = tiny_atlas
    out = tmp_path / "again"
    out.mkdir()
    lines = (done / "cells.jsonl").read_text().splitlines()
    rec = json.loads(lines[1])
    lines[1] = json.dumps(rec | forged)
    (out / "cells.jsonl").write_text("\n".join(lines) + "\n")
    code, stdout = run_main(["atlas", tiny_path, "--out", out, "--workers", "1", "--resume",
                             "--no-plots"])
    assert code == 0 and f"({len(lines) - 2} resumed)" in stdout
    _same_atlas(out, reference)
    assert "garbage" not in (out / "atlas.csv").read_text()

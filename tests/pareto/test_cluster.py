"""A real Dask cluster: ``dask scheduler`` and two ``dask worker`` processes on 127.0.0.1, the
sweep run by ``optdesign pareto --scheduler``, one worker killed with ``kill -9`` while it
computes a point. The scheduler hands that point to the other worker; the front completes
and equals the local run's."""
import os
import signal
import socket
import subprocess
import sys
import time

import pandas as pd
import pytest

from optdesign.fronts.store import Journal
from tests.conftest import ROOT

distributed = pytest.importorskip("distributed")
pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="kill -9, /proc")



def _dask_command() -> list[str]:
    """The ``dask`` command of the cluster extra, next to this interpreter."""
    exe = os.path.join(os.path.dirname(sys.executable), "dask")
    if not os.path.exists(exe):
        pytest.skip("the dask command is not installed (pip install 'optdesign[cluster]')")
    return [exe]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _die_with_test():
    """preexec_fn: the cluster's processes end with the test process, however it ends."""
    import ctypes
    ctypes.CDLL(None).prctl(1, int(signal.SIGKILL), 0, 0, 0)      # PR_SET_PDEATHSIG


@pytest.fixture
def cluster(tmp_path):
    """(scheduler address, {worker name: process}); everything killed afterwards."""
    dask = _dask_command()
    address = f"tcp://127.0.0.1:{_free_port()}"
    env = os.environ | {"PYTHONPATH": str(ROOT)}
    procs = {}

    def start(name, args):
        procs[name] = subprocess.Popen(dask + args, env=env, cwd=tmp_path,
                                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                       preexec_fn=_die_with_test)

    try:
        start("scheduler", ["scheduler", "--host", "127.0.0.1",
                            "--port", address.rsplit(":", 1)[1], "--no-dashboard"])
        for name in ("w0", "w1"):
            start(name, ["worker", address, "--name", name, "--no-nanny", "--nthreads", "1",
                         "--no-dashboard", "--local-directory", str(tmp_path / name)])
        yield address, procs
    finally:
        for proc in procs.values():
            if proc.poll() is None:
                proc.kill()
            proc.wait(timeout=30)


def test_a_killed_worker_does_not_lose_the_front(cluster, small_path, small_front, tmp_path):
    address, procs = cluster
    with distributed.Client(address, timeout=30) as client:
        client.wait_for_workers(2, timeout=60)
        out = tmp_path / "out"
        sweep = subprocess.Popen(
            [sys.executable, "-m", "optdesign", "pareto", str(small_path), "--out", str(out),
             "--scheduler", address, "--no-report"],
            env=os.environ | {"PYTHONPATH": str(ROOT)},
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        journal = out / "points.jsonl"
        victim, killed_at = None, None
        deadline = time.monotonic() + 90
        # once a point is in the journal (the sweep is under way), kill a worker that is
        # computing one
        while victim is None and sweep.poll() is None and time.monotonic() < deadline:
            if journal.exists() and Journal(journal).read()[1]:
                info = client.scheduler_info()["workers"]
                busy = [info[w]["name"] for w, keys in client.processing().items() if keys]
                if busy:
                    victim = busy[0]
                    killed_at = len(Journal(journal).read()[1])
                    os.kill(procs[victim].pid, signal.SIGKILL)
                    break
            time.sleep(0.02)
        stdout, stderr = sweep.communicate(timeout=90)
        assert victim is not None, "the sweep ended before a worker could be killed"
        assert sweep.returncode == 0, stderr
        assert procs[victim].wait(timeout=10) == -signal.SIGKILL
        assert [w["name"] for w in client.scheduler_info()["workers"].values()] == \
            [w for w in ("w0", "w1") if w != victim]
    records = Journal(journal).read()[1]
    keys = [tuple(r["key"]) for r in records]
    assert killed_at < len(keys) == len(set(keys)) == 2 + 4       # mid-sweep; none twice
    got, want = pd.read_csv(out / "pareto.csv"), small_front[0].points
    assert len(got) == 4 and (got["status"] == "optimal").all()
    assert got["delta"].to_numpy() == pytest.approx(want["delta"].to_numpy(), rel=1e-6)
    assert got["ratio"].to_numpy() == pytest.approx(want["ratio"].to_numpy(), rel=1e-8)

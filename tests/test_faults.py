"""Killed runs: nothing lost, nothing mixed, no litter, no orphans, one run per folder.

Each test kills a real ``optdesign`` process (``kill -9`` or SIGTERM) at a moment it chooses:
after 0.5 s, or in the middle of writing a file. For the latter the process runs the CLI under
a wrapper that, at the fsync of the named file's temporary, cuts that temporary to half its
length, prints PAUSED and waits, so the kill lands exactly there.
"""
import json
import os
import select
import signal
import subprocess
import sys
import time

import pandas as pd
import psutil
import pytest
import yaml

from optdesign.cli import main
from optdesign.commands.files import SOLVE_FILES
from optdesign.outputs.provenance import SOURCE

#: what a solve with figures leaves: its files (no failed run's) and the record of its source
RUN_SET = set(SOLVE_FILES) - {"failed_result.json"} | {SOURCE}
from optdesign.fronts.store import Journal
from tests.conftest import ROOT
from tests.pareto.conftest import small

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"),
                                reason="kills processes and reads /proc")

#: runs the CLI; with FAULT_PAUSE_AT=NAME it stops in the middle of writing NAME
WRAPPER = r"""
import os, sys, time
real_fsync = os.fsync
def fsync(fd):
    name = os.path.basename(os.readlink(f"/proc/self/fd/{fd}"))
    target = os.environ.get("FAULT_PAUSE_AT", "")
    if target and name.startswith(f".{target}.") and name.endswith(".tmp"):
        os.ftruncate(fd, os.fstat(fd).st_size // 2)   # a write cut in the middle
        print("PAUSED", flush=True)
        time.sleep(600)
    return real_fsync(fd)
os.fsync = fsync
from optdesign.cli import main
sys.exit(main(sys.argv[1:]))
"""


def _start(args, pause_at=None, stderr=subprocess.DEVNULL):
    env = os.environ | {"PYTHONPATH": str(ROOT)}
    env.pop("FAULT_PAUSE_AT", None)
    if pause_at:
        env["FAULT_PAUSE_AT"] = pause_at
    return subprocess.Popen([sys.executable, "-c", WRAPPER, *map(str, args)], env=env,
                            stdout=subprocess.PIPE, stderr=stderr, text=True)


def _wait_paused(proc, timeout=60):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        ready, _, _ = select.select([proc.stdout], [], [], 0.1)
        if ready:
            line = proc.stdout.readline()
            if line.strip() == "PAUSED":
                return
            assert line, f"exited with {proc.wait()} before pausing"
    raise AssertionError("never paused")


def _kill(proc, sig=signal.SIGKILL):
    proc.send_signal(sig)
    return proc.wait(timeout=30)


def _alive(pids) -> list[int]:
    alive = []
    for pid in pids:
        try:
            if psutil.Process(pid).status() != psutil.STATUS_ZOMBIE:
                alive.append(pid)
        except psutil.NoSuchProcess:
            pass
    return alive


def _orphans(pids, timeout=5.0) -> list[int]:
    """The pids still running (not zombies) after ``timeout`` seconds; killed then, so a
    failing test leaves nothing behind."""
    deadline = time.monotonic() + timeout
    while _alive(pids) and time.monotonic() < deadline:
        time.sleep(0.1)
    alive = _alive(pids)
    for pid in alive:
        os.kill(pid, signal.SIGKILL)
    return alive


def _snapshot(folder):
    return {p.name: p.read_bytes() for p in folder.iterdir()}


def _litter(folder):
    """Temporaries in the folder, and any sibling left by a run (its lock included: a run
    removes it at its end)."""
    temps = [p.name for p in folder.iterdir() if p.name.endswith(".tmp")]
    siblings = [p.name for p in folder.parent.iterdir()
                if p.name.startswith(f".{folder.name}.")]
    return temps + siblings


@pytest.fixture
def problems(tmp_path):
    a = small(points=4)
    a["name"] = "front_a"
    b = small(points=4)
    b["name"] = "front_b"
    b["objective"] = {"min_ratio": 0.84}          # binds: another design than front_a's
    paths = []
    for data in (a, b):
        path = tmp_path / f"{data['name']}.yaml"
        path.write_text(yaml.safe_dump(data))
        paths.append(path)
    return paths


# --------------------------------------------------------------------------- solve
def test_killed_solve_leaves_the_previous_set_whole_and_the_next_run_leaves_no_litter(
        problems, tmp_path):
    a, b = problems
    out = tmp_path / "out"
    assert main(["solve", str(a), "--out", str(out)]) == 0
    before = _snapshot(out)
    assert set(before) == RUN_SET

    # kill -9 in the middle of writing summary.txt (result.json already written), then after
    # 0.5 s (still importing or solving)
    proc = _start(["solve", b, "--out", out, "--force"], pause_at="summary.txt")
    _wait_paused(proc)
    _kill(proc)
    assert _snapshot(out) == before                        # front_a's set, every byte
    leftovers = [p for p in tmp_path.iterdir() if p.name.startswith(".out.new-")]
    assert leftovers and any(p.name.startswith(".summary.txt.")
                             for p in leftovers[0].iterdir())
    proc = _start(["solve", b, "--out", out, "--force"])
    time.sleep(0.5)
    _kill(proc)
    assert _snapshot(out) == before
    (out / ".result.json.x1y2z3.tmp").write_bytes(b'{"name": "fr')   # an older version's

    assert main(["solve", str(b), "--out", str(out), "--force"]) == 0
    after = _snapshot(out)
    assert set(after) == RUN_SET
    assert yaml.safe_load(after["result.json"])["name"] == "front_b"
    assert after["summary.txt"].startswith(b"front_b:")
    assert _litter(out) == []


def test_two_runs_on_one_folder_one_refuses_and_a_killed_holder_blocks_nobody(
        problems, tmp_path, capsys):
    a, b = problems
    out = tmp_path / "out"
    holder = _start(["solve", a, "--out", out, "--no-plots"], pause_at="result.json")
    try:
        _wait_paused(holder)
        assert main(["solve", str(b), "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1
        assert err == (f"optdesign: {out}: another optdesign run (pid {holder.pid}) is "
                       f"writing there; wait for it to finish or choose another --out\n")
        assert main(["pareto", str(b), "--out", str(out)]) == 2     # the same lock
        assert "another optdesign run" in capsys.readouterr().err
    finally:
        _kill(holder)
    assert main(["solve", str(b), "--out", str(out), "--no-plots"]) == 0
    assert sorted(p.name for p in out.iterdir()) == [SOURCE, "design.yaml", "result.json",
                                                     "summary.txt"]
    assert _litter(out) == []


# --------------------------------------------------------------------------- pareto
def _journal_records(path):
    return Journal(path).read()[1] if path.exists() else []


def test_killed_pareto_leaves_no_worker_and_resumes_to_the_uninterrupted_front(problems,
                                                                              tmp_path):
    a, _ = problems
    reference = tmp_path / "reference"
    assert main(["pareto", str(a), "--out", str(reference), "--workers", "1",
                 "--no-report"]) == 0
    out = tmp_path / "out"
    proc = _start(["pareto", a, "--out", out, "--workers", "2", "--no-report"])
    deadline = time.monotonic() + 60
    while not _journal_records(out / "points.jsonl") and time.monotonic() < deadline:
        time.sleep(0.05)
    workers = [c.pid for c in psutil.Process(proc.pid).children()]
    assert _kill(proc) == -signal.SIGKILL
    assert len(workers) == 2
    assert _orphans(workers) == []                             # no orphan goes on computing
    header, done, whole = Journal(out / "points.jsonl").read_to_resume()
    assert whole and 1 <= len(done) < 2 + 4, "killed after the sweep ended"

    assert main(["pareto", str(a), "--out", str(out), "--resume", "--workers", "1",
                 "--no-report"]) == 0
    keys = [tuple(r["key"]) for r in _journal_records(out / "points.jsonl")]
    assert len(keys) == len(set(keys)) == 2 + 4             # nothing lost, nothing twice
    got, want = (pd.read_csv(d / "pareto.csv") for d in (out, reference))
    assert (got["status"] == "optimal").all() and len(got) == 4
    # the same solves from the same starts: equal to IPOPT's tolerance
    assert got["delta"].to_numpy() == pytest.approx(want["delta"].to_numpy(), rel=1e-6)
    assert got["ratio"].to_numpy() == pytest.approx(want["ratio"].to_numpy(), rel=1e-8)
    assert _litter(out) == []


def test_sigterm_ends_pareto_and_its_workers_at_once(problems, tmp_path):
    a, _ = problems
    out = tmp_path / "out"
    proc = _start(["pareto", a, "--out", out, "--workers", "2", "--points", "8",
                   "--no-report"], stderr=subprocess.PIPE)
    deadline = time.monotonic() + 60
    while not _journal_records(out / "points.jsonl") and time.monotonic() < deadline:
        time.sleep(0.05)
    workers = [c.pid for c in psutil.Process(proc.pid).children()]
    t0 = time.monotonic()
    rc = _kill(proc, signal.SIGTERM)
    assert rc == 128 + signal.SIGTERM, proc.stderr.read()
    assert time.monotonic() - t0 < 5
    assert proc.stderr.read().strip().splitlines()[-1] == "optdesign: terminated"
    assert _orphans(workers, timeout=2) == []
    assert Journal(out / "points.jsonl").read_to_resume()[2]      # whole lines only


@pytest.mark.parametrize("guard", ["kernel", "watchdog"])
def test_forked_children_of_a_command_die_with_it(guard):
    """The guard ``solve`` puts on its parallel polishes (the pool's initializer):
    Linux's parent-death signal, or the watchdog thread where there is none."""
    script = ("import os, time, multiprocessing as mp\n"
              "from concurrent.futures import ProcessPoolExecutor\n"
              "from optdesign import lifetime\n"
              + ("lifetime._kill_me_when_parent_dies = lambda: False\n"
                 if guard == "watchdog" else "") +
              "pool = ProcessPoolExecutor(2, mp_context=mp.get_context('fork'),\n"
              "                           initializer=lifetime.die_with_parent,\n"
              "                           initargs=(os.getpid(),))\n"
              "futures = [pool.submit(time.sleep, 60) for _ in range(2)]\n"
              "time.sleep(0.3)\n"
              "print(*pool._processes, flush=True)\n"
              "time.sleep(60)\n")
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True,
                            env=os.environ | {"PYTHONPATH": str(ROOT)})
    children = [int(p) for p in proc.stdout.readline().split()]
    assert len(children) == 2 and _alive(children) == children
    _kill(proc)
    assert _orphans(children, timeout=3) == []


@pytest.mark.parametrize("damage, what", [
    (lambda lines: lines[1:], "the first line is not the run's settings"),
    (lambda lines: lines[:2] + ["{\"key\": [4, 1], \"delta\": 0."] + lines[3:],
     "line 3 is not a record"),
    (lambda lines: lines[:2] + lines[:1] + lines[2:], "line 3 repeats the run's settings"),
])
def test_a_damaged_journal_is_refused_and_left_as_it_is(tmp_path, capsys, damage, what):
    problem = tmp_path / "p.yaml"
    problem.write_text(yaml.safe_dump(small(points=4)))
    out = tmp_path / "out"
    out.mkdir()
    header = {"key": "run", "problem": str(problem)}
    records = [{"key": [4, tag], "phases": 4, "kind": "sweep", "status": "failed",
                "feasible": False, "design": {}, "delta": None, "ratio": None,
                "epsilon": None} for tag in ("least_ripple", 0, 1)]
    lines = damage([json.dumps(r) for r in [header, *records]])
    journal = out / "points.jsonl"
    journal.write_text("\n".join(lines) + "\n")
    before = journal.read_bytes()
    assert main(["pareto", str(problem), "--out", str(out), "--resume", "--workers", "1"]) == 2
    assert capsys.readouterr().err == (f"optdesign: {journal}: damaged journal ({what}); it "
                                       f"is left as it is: run without --resume to start "
                                       f"afresh\n")
    assert journal.read_bytes() == before


# --------------------------------------------------------------------------- the swap, step by step
def _write_set(names, text):
    def write(folder):
        return [folder.joinpath(n).write_text(f"{text} {n}") and folder / n for n in names]
    return write


@pytest.mark.parametrize("atomic_exchange", [True, False])
def test_a_set_replaces_the_previous_one_whole_and_leaves_the_users_files(
        tmp_path, monkeypatch, atomic_exchange):
    from optdesign.outputs import folder as output_dir
    if not atomic_exchange:                     # a platform without renameat2: two renames
        monkeypatch.setattr(output_dir, "_exchange", lambda a, b: False)
    out = tmp_path / "out"
    with output_dir.OutputFolder(out, SOLVE_FILES) as folder:
        folder.replace_with(_write_set(SOLVE_FILES, "old"))
    inode = out.stat().st_ino
    with output_dir.OutputFolder(out, SOLVE_FILES) as folder:
        shown = folder.replace_with(_write_set(SOLVE_FILES[:2], "new"))
    assert shown == [out / n for n in SOLVE_FILES[:2]]
    assert {p.name: p.read_text() for p in out.iterdir()} == {
        n: f"new {n}" for n in SOLVE_FILES[:2]}             # the old figures went with it
    assert out.stat().st_ino != inode                       # a folder of ours: replaced
    (out / "notes.txt").write_text("mine")
    with output_dir.OutputFolder(out, SOLVE_FILES) as folder:
        folder.replace_with(_write_set(SOLVE_FILES, "third"))
    assert (out / "notes.txt").read_text() == "mine"
    assert {p.name for p in out.iterdir()} == {"notes.txt", *SOLVE_FILES}
    assert _litter(out) == []


def test_the_next_run_undoes_or_completes_what_a_kill_left(tmp_path):
    from optdesign.outputs.folder import MARKER, OutputFolder
    old_set = {n: f"old {n}" for n in SOLVE_FILES}

    def make(folder, files):
        folder.mkdir()
        for name, text in files.items():
            (folder / name).write_text(text)

    # killed between the two renames of the fallback: the folder is gone, the old set aside
    out = tmp_path / "a"
    make(tmp_path / ".a.old-1-x", old_set)
    make(tmp_path / ".a.new-1-x", {"result.json": "new", ".summary.txt.abc.tmp": "ne"})
    with OutputFolder(out, SOLVE_FILES):
        pass
    assert {p.name: p.read_text() for p in out.iterdir()} == old_set
    assert _litter(out) == []

    # killed inside an in-place commit: summary.txt still to go in, the old figures to go
    out = tmp_path / "b"
    make(out, old_set | {"result.json": "new result.json", "notes.txt": "mine"})
    make(tmp_path / ".b.commit-2-y", {"summary.txt": "new summary.txt",
                                       MARKER: json.dumps({"owned": list(SOLVE_FILES),
                                                           "files": SOLVE_FILES[:2]})})
    with OutputFolder(out, SOLVE_FILES):
        pass
    assert {p.name: p.read_text() for p in out.iterdir()} == {
        "result.json": "new result.json", "summary.txt": "new summary.txt", "notes.txt": "mine"}
    assert _litter(out) == []

    # a user's file found in a leftover goes back into the folder, never away
    out = tmp_path / "c"
    make(out, old_set)
    make(tmp_path / ".c.new-3-z", {"result.json": "new", "notes.txt": "mine"})
    with OutputFolder(out, SOLVE_FILES):
        pass
    assert {p.name: p.read_text() for p in out.iterdir()} == old_set | {"notes.txt": "mine"}
    assert _litter(out) == []


def test_ctrl_c_during_a_solve_is_one_line_and_no_process_left(tmp_path):
    """Ctrl-C reaches the whole process group while the solve polishes and its figures'
    process waits: that process ignores it and the command ends it, so stderr holds
    "optdesign: interrupted" alone (no "Process ForkProcess-1:", no CasADi warning from an
    interrupted IPOPT) and no process of it outlives the command."""
    env = os.environ | {"PYTHONPATH": str(ROOT), "OPTDESIGN_SERVER": "off"}
    proc = subprocess.Popen([sys.executable, "-m", "optdesign", "solve",
                             str(ROOT / "problems" / "free_design.yaml"), "--out",
                             str(tmp_path / "o")], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    children, deadline = [], time.monotonic() + 60
    while not children and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)                       # until the figures' process is forked
        children = [c.pid for c in psutil.Process(proc.pid).children(recursive=True)]
    assert children, "the solve ended, or forked no process within a minute"
    time.sleep(0.8)                            # into the polishes (free_design: 5 counts)
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130
    assert err.splitlines() == ["optdesign: interrupted"], err
    assert _orphans(children) == []

"""A warm server of each test module's own, in a private folder, and the runs that reach it."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PROGRAM = [sys.executable, "-m", "optdesign"]


def server_env(folder: Path, **more) -> dict:
    return os.environ | {"OPTDESIGN_SERVER": "on", "OPTDESIGN_SERVER_DIR": str(folder),
                         "OPTDESIGN_SERVER_IDLE": "120", "PYTHONPATH": str(ROOT)} | more


def run_program(args, env, cwd=ROOT, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([*PROGRAM, *map(str, args)], env=env, cwd=cwd, capture_output=True,
                          text=True, timeout=300, **kw)


def served_by(run_args, env, tmp_path, cwd=ROOT) -> tuple[subprocess.CompletedProcess, bool]:
    """(the finished run, whether the server's child ran it): the phase line's pid is the
    process that ran the command."""
    log = tmp_path / f"phases-{time.monotonic_ns()}.jsonl"
    proc = subprocess.Popen([*PROGRAM, *map(str, run_args)], env=env | {
        "OPTDESIGN_PHASES": str(log)}, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        text=True)
    out, err = proc.communicate(timeout=300)
    records = [json.loads(line) for line in log.read_text().splitlines()] if log.exists() \
        else []
    assert len(records) == 1, records           # one line, from the process that ran it
    return (subprocess.CompletedProcess(proc.args, proc.returncode, out, err),
            records[0]["pid"] != proc.pid)


@pytest.fixture(scope="module")
def warm():
    """A running server in a private folder of its own: the environment that reaches it."""
    folder = Path(tempfile.mkdtemp(prefix="odw")) / "s"
    env = server_env(folder)
    started = run_program(["server", "start"], env)
    assert started.returncode == 0, started.stderr
    yield env
    run_program(["server", "stop"], env)


def status(env) -> dict | None:
    run = run_program(["server", "status", "--json"], env)
    assert run.returncode == 0, run.stderr
    state = json.loads(run.stdout)
    return state if state["running"] else None


def alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True

"""Callers and clients the warm server meets, and what the user sees: the same as run alone.

- Signals the caller ignores stay ignored in every process of the command.
- A client sending its request a byte at a time, or connections that send nothing, delay no
  other command; the server drops them at their deadline.
- A server stopped by SIGSTOP is given up after a few seconds, and the command runs alone,
  once, with the same output.
- Under the C locale (no LANG, no LC_*) a command is served by the server that is running.
"""
from __future__ import annotations

import os
import signal
import socket
import subprocess
import threading
import time

import psutil
import yaml

from optdesign.warm import client, place, server, wire
from tests.pareto.conftest import small
from tests.warm.conftest import PROGRAM, ROOT, run_program, served_by, status

IGNORED = (signal.SIGHUP, signal.SIGINT, signal.SIGQUIT)


def _ignore():
    for signum in IGNORED:
        signal.signal(signum, signal.SIG_IGN)


def _forked(runner) -> psutil.Process:
    """The process running the command (``runner()``), once it has forked its two workers
    and its figures' process."""
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        try:
            process = runner()
            if process is not None and len(process.children(recursive=True)) >= 3:
                return process
        except psutil.NoSuchProcess:
            pass
        time.sleep(0.05)
    raise AssertionError("the command never forked its workers")


def test_nohup_and_background_job_signals_stay_ignored_warm_and_cold(warm, tmp_path):
    """``nohup optdesign pareto P.yaml &`` in a script ignores SIGHUP (nohup), SIGINT and
    SIGQUIT (a script's background job); each is sent to every process group of the command
    (the program's; warm, the server's child's) once its pool workers and figures' process
    run, and the run finishes as if nothing came."""
    problem = tmp_path / "p.yaml"
    data = small(points=2)
    data["solver"]["starts"] = 1
    problem.write_text(yaml.safe_dump(data))
    server = psutil.Process(status(warm)["pid"])
    runs, runners = {}, {}
    for way, env in (("warm", warm), ("cold", warm | {"OPTDESIGN_SERVER": "off"})):
        runs[way] = proc = subprocess.Popen(
            [*PROGRAM, "pareto", problem, "--out", tmp_path / way, "--workers", "2"],
            env=env, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
            start_new_session=True, preexec_fn=_ignore)
        runners[way] = ((lambda: next(iter(server.children()), None)) if way == "warm"
                        else (lambda pid=proc.pid: psutil.Process(pid)))
    for way, proc in runs.items():
        command = _forked(runners[way])
        for signum in IGNORED:
            for group in {proc.pid, command.pid}:
                os.killpg(group, signum)
    for way, proc in runs.items():
        out, err = proc.communicate(timeout=120)
        assert proc.returncode == 0, (way, err)
        assert "Traceback" not in err and "interrupted" not in err, (way, err)
        assert (tmp_path / way / "pareto.csv").exists(), way


def test_slow_and_idle_clients_delay_no_command_and_are_dropped(warm, tmp_path):
    path = os.fspath(place.socket_path(warm))
    idle = []
    for _ in range(10):
        conn = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        conn.connect(path)
        idle.append(conn)
    slow = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    slow.connect(path)
    stop = threading.Event()

    def dribble():                     # a request's length, a byte every 0.2 s
        for byte in (1 << 20).to_bytes(8, "big") + b"{" * 100:
            if stop.wait(0.2):
                return
            try:
                slow.send(bytes([byte]))
            except OSError:            # dropped by the server
                return
    sender = threading.Thread(target=dribble)
    sender.start()
    try:
        began = time.monotonic()
        run, served = served_by(["--version"], warm, tmp_path)
        assert run.returncode == 0 and served
        assert time.monotonic() - began < server.REQUEST_TIMEOUT_S
        for conn in [*idle, slow]:     # greeted, then closed at its deadline, not before
            conn.settimeout(server.REQUEST_TIMEOUT_S + 10)
            assert b"".join(iter(lambda c=conn: c.recv(64), b"")) == wire.READY
        assert time.monotonic() - began >= server.REQUEST_TIMEOUT_S - 1
    finally:
        stop.set()
        sender.join()
        for conn in [*idle, slow]:
            conn.close()


def test_a_stopped_server_is_given_up_and_the_command_runs_alone_once(warm, tmp_path):
    pid = status(warm)["pid"]
    cold = run_program(["--version"], warm | {"OPTDESIGN_SERVER": "off"})
    os.kill(pid, signal.SIGSTOP)
    try:
        began = time.monotonic()
        run, served = served_by(["--version"], warm, tmp_path)
        waited = time.monotonic() - began
    finally:
        os.kill(pid, signal.SIGCONT)
    assert not served and waited >= client.HANDSHAKE_TIMEOUT_S
    assert (run.returncode, run.stdout, run.stderr) == (0, cold.stdout, cold.stderr)
    deadline = time.monotonic() + 30       # the child it forked late ends, running nothing
    while status(warm)["commands_running"] and time.monotonic() < deadline:
        time.sleep(0.1)
    assert status(warm)["pid"] == pid and status(warm)["commands_running"] == 0
    logs = list(tmp_path.glob("phases-*.jsonl"))
    assert len(logs) == 1 and len(logs[0].read_text().splitlines()) == 1


def test_a_command_under_the_c_locale_is_served_by_the_running_server(warm, tmp_path):
    """The C locale turns on UTF-8 mode in the command and not in a server (it is handed
    LC_CTYPE=C.UTF-8): no reason for another server."""
    c_locale = {k: v for k, v in warm.items()
                if not k.startswith(("LANG", "LC_", "PYTHONUTF8", "PYTHONIOENCODING"))}
    pid = status(warm)["pid"]
    cold = run_program(["analyze", "problems/sharkov2022.yaml"],
                       c_locale | {"OPTDESIGN_SERVER": "off"})
    run, served = served_by(["analyze", "problems/sharkov2022.yaml"], c_locale, tmp_path)
    assert served and (run.returncode, run.stdout, run.stderr) == (0, cold.stdout, cold.stderr)
    assert "ω" in run.stdout
    assert status(c_locale)["pid"] == pid           # the same server, not stale

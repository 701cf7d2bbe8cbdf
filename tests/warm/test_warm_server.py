"""The warm server (optdesign.warm): a command it runs behaves as the program run alone, in
every way a user or a script can see: output, exit code, files and their modes, the working
folder, signals; it serves only a private folder and only its own installation."""
from __future__ import annotations

import json
import os
import signal
import stat
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[2]
PROGRAM = [sys.executable, "-m", "optdesign"]
#: a solve of about ten seconds
SLOW = {"screen": 65536, "workers": 1, "samples": 200, "basins": 8, "starts": 16}


def _env(folder: Path, **more) -> dict:
    return os.environ | {"OPTDESIGN_SERVER": "on", "OPTDESIGN_SERVER_DIR": str(folder),
                         "OPTDESIGN_SERVER_IDLE": "120", "PYTHONPATH": str(ROOT)} | more


def _run(args, env, cwd=ROOT, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([*PROGRAM, *map(str, args)], env=env, cwd=cwd, capture_output=True,
                          text=True, timeout=300, **kw)


def _served_by(run_args, env, tmp_path, cwd=ROOT) -> tuple[subprocess.CompletedProcess, bool]:
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
    env = _env(folder)
    started = _run(["server", "start"], env)
    assert started.returncode == 0, started.stderr
    yield env
    _run(["server", "stop"], env)


def test_a_command_run_warm_prints_and_exits_as_run_alone(warm, tmp_path):
    cold_env = warm | {"OPTDESIGN_SERVER": "off"}
    for args in (["analyze", "problems/sharkov2022.yaml"],
                 ["analyze", "problems/no_such_file.yaml"],         # exit 2, one line
                 ["analyze", "problems/sharkov2022.yaml", "--design", "README.md"],
                 ["--version"]):
        hot, served = _served_by(args, warm, tmp_path)
        cold = _run(args, cold_env)
        assert served, args
        assert (hot.returncode, hot.stdout, hot.stderr) == \
               (cold.returncode, cold.stdout, cold.stderr), args
    assert _run(["analyze", "problems/no_such_file.yaml"], warm).returncode == 2


def test_a_solve_run_warm_writes_the_same_set_with_the_same_modes(warm, tmp_path):
    work = tmp_path / "work"
    work.mkdir()
    (work / "p.yaml").write_text((ROOT / "problems" / "sharkov2022_disc.yaml").read_text())
    sets = {}
    for name, env in (("hot", warm), ("cold", warm | {"OPTDESIGN_SERVER": "off"})):
        args = ["solve", "p.yaml", "--out", name, "--json"]
        run = subprocess.run(["sh", "-c", 'umask 027 && exec "$@"', "sh", *PROGRAM, *args],
                             env=env, cwd=work, capture_output=True, text=True, timeout=300)
        assert run.returncode == 0, run.stderr
        sets[name] = (json.loads(run.stdout), {p.name: stat.S_IMODE(p.stat().st_mode)
                                               for p in (work / name).iterdir()})
    (hot, hot_modes), (cold, cold_modes) = sets["hot"], sets["cold"]
    assert hot["design"] == cold["design"] and hot["status"] == cold["status"] == "optimal"
    assert hot_modes == cold_modes and "mechanism.png" in hot_modes
    assert all(mode & 0o007 == 0 for mode in hot_modes.values())      # the umask 027
    for name in ("mechanism.png", "speeds.png", "animation.html"):       # drawn the same
        assert (work / "hot" / name).read_bytes() == (work / "cold" / name).read_bytes()


def _slow_solve(env, tmp_path) -> subprocess.Popen:
    """A solve of about ten seconds, two seconds under way."""
    problem = tmp_path / "slow.yaml"
    data = yaml.safe_load((ROOT / "problems" / "sharkov2022_disc.yaml").read_text())
    data["solver"] = SLOW
    problem.write_text(yaml.safe_dump(data))
    proc = subprocess.Popen([*PROGRAM, "solve", str(problem), "--out", str(tmp_path / "o")],
                            env=env, cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    time.sleep(2.0)
    return proc


def test_ctrl_c_reaches_the_command_and_ends_it_as_interrupted(warm, tmp_path):
    proc = _slow_solve(warm, tmp_path)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert err.strip().splitlines()[-1] == "optdesign: interrupted"
    assert not (tmp_path / "o").exists() or not any((tmp_path / "o").iterdir())
    assert _status(warm)["commands_running"] == 0


def test_a_killed_client_ends_its_command(warm, tmp_path):
    proc = _slow_solve(warm, tmp_path)
    assert _status(warm)["commands_running"] == 1
    proc.kill()
    proc.wait()
    deadline = time.monotonic() + 30
    while _status(warm)["commands_running"] and time.monotonic() < deadline:
        time.sleep(0.2)
    assert _status(warm)["commands_running"] == 0


def test_a_folder_others_may_enter_or_a_link_is_never_used(tmp_path):
    shared = tmp_path / "shared"
    shared.mkdir(mode=0o755)
    shared.chmod(0o755)
    private = tmp_path / "private"
    private.mkdir(mode=0o700)
    link = tmp_path / "link"
    link.symlink_to(private)
    for folder in (shared, link):
        env = _env(folder)
        run, served = _served_by(["--version"], env, tmp_path)
        assert run.returncode == 0 and not served
        start = _run(["server", "start"], env)
        assert start.returncode == 1 and "mode 0700, not a link" in start.stderr
        assert list(shared.iterdir()) == [] and list(private.iterdir()) == []


def test_a_bad_setting_is_one_line_and_exit_2(tmp_path):
    run = _run(["--version"], _env(tmp_path / "s", OPTDESIGN_SERVER="sometimes"))
    assert run.returncode == 2
    assert run.stderr.strip() == ("optdesign: environment variable OPTDESIGN_SERVER: expected "
                                  "on or off, got 'sometimes'")
    off = _run(["server", "start"], _env(tmp_path / "s", OPTDESIGN_SERVER="off"))
    assert off.returncode == 2 and len(off.stderr.strip().splitlines()) == 1


def test_a_command_that_finds_no_server_starts_one_which_ends_when_idle(tmp_path):
    env = _env(tmp_path / "s", OPTDESIGN_SERVER_IDLE="4")
    assert _status(env) is None
    run, served = _served_by(["analyze", "problems/sharkov2022.yaml"], env, tmp_path)
    assert run.returncode == 0 and not served
    deadline = time.monotonic() + 60
    while (_status(env) is None) and time.monotonic() < deadline:
        time.sleep(0.1)
    try:
        assert _status(env) is not None
        again, served = _served_by(["analyze", "problems/sharkov2022.yaml"], env, tmp_path)
        assert served and again.stdout == run.stdout
        deadline = time.monotonic() + 30      # four seconds without a command: it ends
        while _status(env) is not None and time.monotonic() < deadline:
            time.sleep(0.2)
        assert _status(env) is None
        assert not list((tmp_path / "s").glob("*.sock"))
    finally:
        _run(["server", "stop"], env)


def test_a_client_of_another_environment_runs_alone_and_the_stale_server_ends(warm,
                                                                              tmp_path):
    """Last of the module: it ends the module's server."""
    assert _run(["server", "start"], warm).returncode == 0      # started again if need be
    first = _status(warm)["pid"]
    other = warm | {"MPLBACKEND": "svg"}
    run, served = _served_by(["--version"], other, tmp_path)
    assert run.returncode == 0 and not served
    deadline = time.monotonic() + 10
    while _alive(first) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not _alive(first)
    _run(["server", "stop"], other)         # the one that run started, for its environment


def _status(env) -> dict | None:
    run = _run(["server", "status", "--json"], env)
    assert run.returncode == 0, run.stderr
    state = json.loads(run.stdout)
    return state if state["running"] else None


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True

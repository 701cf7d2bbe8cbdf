"""The warm server (optdesign.warm): a command it runs behaves as the program run alone, in
every way a user or a script can see: output, exit code, files and their modes, the working
folder, signals; it serves only a private folder and only its own installation."""
from __future__ import annotations

import json
import signal
import stat
import subprocess
import time

import yaml

from tests.warm.conftest import (PROGRAM, ROOT, alive, run_program, served_by, server_env,
                                 status)

#: a solve of about ten seconds
SLOW = {"screen": 65536, "workers": 1, "samples": 200, "basins": 8, "starts": 16}


def test_a_command_run_warm_prints_and_exits_as_run_alone(warm, tmp_path):
    cold_env = warm | {"OPTDESIGN_SERVER": "off"}
    for args in (["analyze", "problems/sharkov2022.yaml"],
                 ["analyze", "problems/no_such_file.yaml"],         # exit 2, one line
                 ["analyze", "problems/sharkov2022.yaml", "--design", "README.md"],
                 ["--version"]):
        hot, served = served_by(args, warm, tmp_path)
        cold = run_program(args, cold_env)
        assert served, args
        assert (hot.returncode, hot.stdout, hot.stderr) == \
               (cold.returncode, cold.stdout, cold.stderr), args
    assert run_program(["analyze", "problems/no_such_file.yaml"], warm).returncode == 2


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
    assert status(warm)["commands_running"] == 0


def test_a_killed_client_ends_its_command(warm, tmp_path):
    proc = _slow_solve(warm, tmp_path)
    assert status(warm)["commands_running"] == 1
    proc.kill()
    proc.wait()
    deadline = time.monotonic() + 30
    while status(warm)["commands_running"] and time.monotonic() < deadline:
        time.sleep(0.2)
    assert status(warm)["commands_running"] == 0


def test_a_folder_others_may_enter_or_a_link_is_never_used(tmp_path):
    shared = tmp_path / "shared"
    shared.mkdir(mode=0o755)
    shared.chmod(0o755)
    private = tmp_path / "private"
    private.mkdir(mode=0o700)
    link = tmp_path / "link"
    link.symlink_to(private)
    for folder in (shared, link):
        env = server_env(folder)
        run, served = served_by(["--version"], env, tmp_path)
        assert run.returncode == 0 and not served
        start = run_program(["server", "start"], env)
        assert start.returncode == 1 and "mode 0700, not a link" in start.stderr
        assert list(shared.iterdir()) == [] and list(private.iterdir()) == []


def test_a_bad_setting_is_one_line_and_exit_2(tmp_path):
    run = run_program(["--version"],
                      server_env(tmp_path / "s", OPTDESIGN_SERVER="sometimes"))
    assert run.returncode == 2
    assert run.stderr.strip() == ("optdesign: environment variable OPTDESIGN_SERVER: expected "
                                  "on or off, got 'sometimes'")
    off = run_program(["server", "start"],
                      server_env(tmp_path / "s", OPTDESIGN_SERVER="off"))
    assert off.returncode == 2 and len(off.stderr.strip().splitlines()) == 1


def test_a_command_that_finds_no_server_starts_one_which_ends_when_idle(tmp_path):
    env = server_env(tmp_path / "s", OPTDESIGN_SERVER_IDLE="4")
    assert status(env) is None
    run, served = served_by(["analyze", "problems/sharkov2022.yaml"], env, tmp_path)
    assert run.returncode == 0 and not served
    deadline = time.monotonic() + 60
    while (status(env) is None) and time.monotonic() < deadline:
        time.sleep(0.1)
    try:
        assert status(env) is not None
        again, served = served_by(["analyze", "problems/sharkov2022.yaml"], env, tmp_path)
        assert served and again.stdout == run.stdout
        deadline = time.monotonic() + 30      # four seconds without a command: it ends
        while status(env) is not None and time.monotonic() < deadline:
            time.sleep(0.2)
        assert status(env) is None
        assert not list((tmp_path / "s").glob("*.sock"))
    finally:
        run_program(["server", "stop"], env)


def test_a_client_of_another_environment_runs_alone_and_the_stale_server_ends(warm,
                                                                              tmp_path):
    """Last of the module: it ends the module's server."""
    assert run_program(["server", "start"], warm).returncode == 0   # started again if need be
    first = status(warm)["pid"]
    other = warm | {"MPLBACKEND": "svg"}
    run, served = served_by(["--version"], other, tmp_path)
    assert run.returncode == 0 and not served
    deadline = time.monotonic() + 10
    while alive(first) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not alive(first)
    run_program(["server", "stop"], other)         # the one that run started, for its environment

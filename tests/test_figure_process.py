"""Figures drawn beside the command: in processes of their own, in order, their errors raised
in the command as they were raised there, nothing left running (each test well under a
second: the jobs here draw nothing)."""
import errno
import json
import os
import signal
import subprocess
import sys
import time

import psutil
import pytest

from optdesign.cli import main
from optdesign.errors import OptDesignError
from optdesign.outputs.figure_process import FigureProcess
from tests.conftest import ROOT

pytestmark = pytest.mark.skipif(not hasattr(os, "fork"), reason="draws beside by forking")

DRIVELINE_FILE = str(ROOT / "problems" / "driveline.yaml")


def pid_and(value):
    return os.getpid(), value


def full_disk(*args, **kwargs):
    """A figure whose file (the last argument) finds the disk full."""
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(args[-1]))


def killed(*args):
    os.kill(os.getpid(), signal.SIGKILL)


def _gone(pid: int) -> bool:
    """Ended: no such process, or a zombie its new parent has not reaped yet."""
    try:
        return psutil.Process(pid).status() == psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return True


def test_the_figures_are_drawn_beside_at_once_and_come_back_in_order():
    with FigureProcess() as figures:
        figures.draw([(pid_and, (k,)) for k in range(3)])
        got = figures.wait()
    assert [v for _, v in got] == [0, 1, 2]
    pids = {p for p, _ in got}
    assert os.getpid() not in pids and len(pids) == 3      # each in a process of its own


def test_without_a_process_the_figures_are_drawn_here():
    with FigureProcess(enabled=False) as figures:
        figures.draw([(pid_and, ("here",))])
        assert figures.wait() == [(os.getpid(), "here")]


def test_a_figures_error_is_raised_in_the_command_as_it_was():
    with FigureProcess() as figures:
        figures.draw([(pid_and, (1,)), (full_disk, ("/x/speeds.png",))])
        with pytest.raises(OSError) as raised:
            figures.wait()
    assert raised.value.errno == errno.ENOSPC and raised.value.filename == "/x/speeds.png"
    assert "in the process that draws them" in "".join(getattr(raised.value, "__notes__", []))


def test_a_killed_figures_process_is_one_clear_error():
    with FigureProcess() as figures:
        figures.draw([(killed, ())])
        with pytest.raises(OptDesignError, match="ended before it finished"):
            figures.wait()


def test_leaving_the_block_ends_a_process_still_warming_up():
    with FigureProcess(warm=lambda: time.sleep(60)) as figures:
        pid = figures._pid
    assert pid is not None and _gone(pid)


def test_the_figures_process_dies_with_the_command():
    script = ("import time\n"
              "from optdesign.outputs.figure_process import FigureProcess\n"
              "f = FigureProcess(warm=lambda: time.sleep(60))\n"
              "print(f._pid, flush=True)\n"
              "time.sleep(60)\n")
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True,
                            env=os.environ | {"PYTHONPATH": str(ROOT)})
    helper = int(proc.stdout.readline())
    assert not _gone(helper)
    proc.kill()
    proc.wait(timeout=10)
    deadline = time.monotonic() + 3
    while not _gone(helper) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert _gone(helper)


def test_a_command_prints_its_answer_first_and_a_failed_figure_is_one_line(
        tmp_path, capsys, monkeypatch):
    from optdesign.commands import files

    monkeypatch.setattr(files, "write_driveline", full_disk)
    code = main(["driveline", DRIVELINE_FILE, "--out", str(tmp_path), "--json"])
    out, err = capsys.readouterr()
    assert code == 1
    assert json.loads(out)["figure"].endswith("driveline.png")       # the answer came first
    assert err.count("\n") == 1
    assert err.startswith("optdesign driveline: No space left on device: ")
    assert "driveline.png" in err

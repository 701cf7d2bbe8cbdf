"""Standard streams that fail no result (optdesign.outputs.streams): a closed stdout or
stderr, or one whose encoding lacks ω, changes neither the exit code nor what is written."""
import subprocess
import sys

import pytest

from optdesign.outputs.streams import ascii_name
from tests.conftest import ROOT

ANALYZE = [sys.executable, "-m", "optdesign", "analyze", "problems/sharkov2022.yaml"]


def _closing(*fds):
    import os

    def close():
        for fd in fds:
            os.close(fd)
    return close


@pytest.mark.parametrize("closed", [(1,), (2,), (0, 1, 2)], ids=[">&-", "2>&-", "all"])
def test_a_closed_standard_stream_changes_no_exit_code(closed):
    run = subprocess.run(ANALYZE, cwd=ROOT, capture_output=True, text=True, timeout=120,
                         preexec_fn=_closing(*closed))
    assert run.returncode == 0
    assert run.stdout == "" if 1 in closed else "least transmission angle" in run.stdout
    assert run.stderr == ""


def test_an_ascii_stream_gets_ascii_names():
    run = subprocess.run([*ANALYZE, "--design", "no_such_ω.json"], cwd=ROOT,
                         capture_output=True, timeout=120,
                         env={"PATH": "/usr/bin:/bin", "PYTHONIOENCODING": "ascii",
                              "OPTDESIGN_SERVER": "off"})
    assert run.returncode == 2
    assert b"no_such_omega.json" in run.stderr and len(run.stderr.splitlines()) == 1
    run = subprocess.run(ANALYZE, cwd=ROOT, capture_output=True, timeout=120,
                         env={"PATH": "/usr/bin:/bin", "PYTHONIOENCODING": "ascii",
                              "OPTDESIGN_SERVER": "off"})
    assert run.returncode == 0 and run.stderr == b""
    assert b"omega1 = 97 rad/s" in run.stdout and b"delta" in run.stdout
    run.stdout.decode("ascii")


@pytest.mark.parametrize("char, name", [("ω", "omega"), ("δ", "delta"), ("μ", "mu"),
                                        ("°", "deg"), ("Δ", "Delta"), ("²", "^2"),
                                        ("é", "e"), ("ω̇", "omega"), ("☃", "?")])
def test_ascii_names(char, name):
    assert "".join(ascii_name(c) for c in char) == name

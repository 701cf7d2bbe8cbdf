"""Writes that fail: a disk that fills while a command writes its set leaves the earlier set
whole and names the file it could not write in one line (exit 1); a folder planted under the
name of one of optdesign's temporaries is refused in one line (exit 2), the lock not left."""
import errno
import os
import re
import subprocess

import pytest

from optdesign.cli import main
from tests.conftest import ROOT

TOLERANCE = ROOT / "problems" / "sharkov2022_disc_tolerance.yaml"
PAPER = ROOT / "problems" / "sharkov2022.yaml"
FREE = ROOT / "problems" / "sharkov2022_disc.yaml"


def _snapshot(folder):
    return {p.name: p.read_bytes() for p in folder.iterdir()}


def _litter(folder):
    """Temporaries in the folder, and anything a run leaves beside it (its lock included)."""
    return ([p.name for p in folder.iterdir() if p.name.endswith(".tmp")]
            + [p.name for p in folder.parent.iterdir() if p.name.startswith(f".{folder.name}.")])


@pytest.fixture
def disk(tmp_path):
    """A folder on a file system of 150 kB (a tmpfs), unmounted after the test."""
    where = tmp_path / "disk"
    where.mkdir()
    mount = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=150k", "tmpfs", str(where)],
                           capture_output=True)
    if mount.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {mount.stderr.decode().strip()}")
    yield where
    subprocess.run(["umount", str(where)], check=False)


def test_a_disk_full_during_tolerance_leaves_the_earlier_set_and_names_the_file(
        disk, capsys, monkeypatch):
    """An earlier set of 90 kB fills most of the disk: the new one does not fit beside it."""
    monkeypatch.chdir(disk)
    (disk / "tol").mkdir()
    for name, size in (("tolerance.json", 8), ("tolerance.csv", 25), ("tolerance.png", 57)):
        (disk / "tol" / name).write_bytes(os.urandom(size * 1024))
    earlier = _snapshot(disk / "tol")
    assert main(["tolerance", str(TOLERANCE), "--out", "tol", "--samples", "200"]) == 1
    err = capsys.readouterr().err
    assert re.fullmatch(r"optdesign tolerance: No space left on device: "
                        r"'tol/tolerance\.(json|csv|png)'\n", err), err
    after = _snapshot(disk / "tol")
    # a folder without a record of its problem file is claimed by the first run into it
    claimed = after.pop(".optdesign-source.json")
    assert str(TOLERANCE.resolve()).encode() in claimed
    assert after == earlier and _litter(disk / "tol") == []


def test_a_disk_full_during_export_leaves_the_earlier_set(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "out"
    assert main(["export", str(PAPER), "--out", "out"]) == 0
    earlier = _snapshot(out)
    real = os.fsync

    def full(fd):                                  # the second file of the set finds no room
        if os.readlink(f"/proc/self/fd/{fd}").split("/")[-1].startswith(".linkage.svg."):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real(fd)
    monkeypatch.setattr(os, "fsync", full)
    capsys.readouterr()
    assert main(["export", str(PAPER), "--out", "out", "--angle", "30"]) == 1
    assert capsys.readouterr().err == \
        "optdesign export: No space left on device: 'out/linkage.svg'\n"
    assert _snapshot(out) == earlier and _litter(out) == []


def test_a_folder_named_as_a_temporary_is_refused_and_the_lock_not_left(tmp_path, capsys):
    out = tmp_path / "out"
    (out / ".result.json.X.tmp").mkdir(parents=True)
    assert main(["solve", str(FREE), "--out", str(out), "--no-plots"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and ".result.json.X.tmp: is a folder where optdesign keeps "
    assert "a temporary file" in err and "Traceback" not in err
    assert os.listdir(out) == [".result.json.X.tmp"] and _litter(out) == [".result.json.X.tmp"]

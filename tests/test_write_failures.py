"""Writes that fail: a folder planted under the name of one of optdesign's temporaries is
refused in one line (exit 2), the lock not left."""
import os

import pytest

from optdesign.cli import main
from tests.conftest import ROOT

FREE = ROOT / "problems" / "sharkov2022_disc.yaml"


def _litter(folder):
    """Temporaries in the folder, and anything a run leaves beside it (its lock included)."""
    return ([p.name for p in folder.iterdir() if p.name.endswith(".tmp")]
            + [p.name for p in folder.parent.iterdir() if p.name.startswith(f".{folder.name}.")])


def test_a_folder_named_as_a_temporary_is_refused_and_the_lock_not_left(tmp_path, capsys):
    out = tmp_path / "out"
    (out / ".result.json.X.tmp").mkdir(parents=True)
    assert main(["solve", str(FREE), "--out", str(out), "--no-plots"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and ".result.json.X.tmp: is a folder where optdesign keeps "
    assert "a temporary file" in err and "Traceback" not in err
    assert os.listdir(out) == [".result.json.X.tmp"] and _litter(out) == [".result.json.X.tmp"]

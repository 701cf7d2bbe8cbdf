"""Atomic writes: the usual file rights, and nothing half-written when writing fails."""
import os
import stat

import pytest

from optdesign.outputs.atomic import atomic_write_json, atomic_write_text


def test_written_file_has_the_usual_rights(tmp_path):
    old = os.umask(0o022)
    try:
        path = atomic_write_text(tmp_path / "a.txt", "x")
    finally:
        os.umask(old)
    assert stat.S_IMODE(path.stat().st_mode) == 0o644


def test_failed_write_leaves_the_old_file_and_no_temporary(tmp_path):
    path = atomic_write_json(tmp_path / "r.json", {"status": "optimal"})
    with pytest.raises(TypeError):
        atomic_write_json(path, {"bad": object()})
    assert path.read_text().strip().startswith("{")
    assert '"optimal"' in path.read_text()
    assert [p.name for p in tmp_path.iterdir()] == ["r.json"]

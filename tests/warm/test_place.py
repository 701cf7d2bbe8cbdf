"""Which server a command may use (optdesign.warm.place): its fingerprint and its folder."""
from __future__ import annotations

import os

import pytest

from optdesign.warm import place


def test_the_fingerprint_follows_the_files_and_the_variables_read_at_import(tmp_path,
                                                                             monkeypatch):
    monkeypatch.setattr(place, "PACKAGE", tmp_path)
    source = tmp_path / "module.py"
    source.write_text("x = 1\n")
    env = {"PATH": "/usr/bin", "OMP_NUM_THREADS": "2"}
    first = place.fingerprint(env)
    assert place.fingerprint(dict(env)) == first
    # read when a command runs, not when the libraries are imported: the same server serves
    # (the locale and the streams' encoding too: the child takes them on from the client)
    for k, v in {"PATH": "/bin", "OPTDESIGN_PHASES": "/tmp/x", "OPTDESIGN_SERVER": "on",
                 "COLUMNS": "80", "LANG": "C", "LC_ALL": "C.UTF-8",
                 "PYTHONIOENCODING": "ascii"}.items():
        assert place.fingerprint(env | {k: v}) == first, k
    for k, v in {"OMP_NUM_THREADS": "1", "MPLBACKEND": "svg", "PYTHONPATH": "/x",
                 "OPTDESIGN_OTHER": "1"}.items():
        assert place.fingerprint(env | {k: v}) != first, k
    st = source.stat()
    os.utime(source, ns=(st.st_atime_ns, st.st_mtime_ns + 1))
    assert place.fingerprint(env) != first
    (tmp_path / "__pycache__").mkdir()
    touched = place.fingerprint(env)
    (tmp_path / "__pycache__" / "module.cpython-311.pyc").write_bytes(b"\0")
    assert place.fingerprint(env) == touched          # compiled files are no change


def test_only_a_folder_of_this_user_that_no_one_else_enters_is_private(tmp_path):
    made = tmp_path / "made"
    assert not place.private(made)
    assert place.private(made, create=True)
    assert os.stat(made).st_mode & 0o777 == 0o700
    open_ = tmp_path / "open"
    open_.mkdir()
    open_.chmod(0o755)
    assert not place.private(open_, create=True)
    link = tmp_path / "link"
    link.symlink_to(made)
    assert not place.private(link)
    assert not place.private(tmp_path / "no" / "parent", create=True)


def test_a_socket_path_too_long_for_a_unix_socket_is_none():
    assert place.socket_path({place.FOLDER_VARIABLE: "/tmp/" + "x" * 120}) is None
    assert place.socket_path({place.FOLDER_VARIABLE: "/tmp/s"}).name.endswith(".sock")


@pytest.mark.parametrize("value", ["maybe", "2"])
def test_a_setting_it_does_not_take_is_named(value):
    with pytest.raises(place.SettingError, match="OPTDESIGN_SERVER"):
        place.enabled({place.VARIABLE: value})
    with pytest.raises(place.SettingError, match="OPTDESIGN_SERVER_IDLE"):
        place.idle_seconds({place.IDLE_VARIABLE: value if value != "2" else "-2"})
    assert place.enabled({place.VARIABLE: "OFF"}) is False
    assert place.enabled({}) is True

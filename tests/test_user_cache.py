"""The files of the user's cache a process may trust (optdesign.numerics.user_cache): the
checks made on the file where it lies, mapped (intact) or read (trusted), agree; a link, a
pipe, a file cut short or changed, another's and one made from something else are refused."""
import logging
import os
import threading

import pytest

from optdesign.numerics import user_cache

TAG, DIGEST = "optdesign-test", "d" * 64


@pytest.fixture
def sealed(tmp_path):
    path = tmp_path / "thing.bin"
    body = bytes(range(256)) * 4096                   # a megabyte, as a small library
    user_cache.keep(path, TAG, DIGEST, body)
    return path, body


def test_a_sealed_file_is_trusted_and_intact(sealed):
    path, body = sealed
    assert user_cache.trusted(path, TAG, DIGEST) == body
    assert user_cache.intact(path, TAG, DIGEST)
    assert oct(path.stat().st_mode & 0o777) == oct(0o600)


@pytest.mark.parametrize("spoil", ["bit", "short", "digest", "tag", "empty", "writable"])
def test_a_spoiled_file_is_refused_by_both(sealed, spoil):
    path, body = sealed
    data = bytearray(path.read_bytes())
    digest, tag = DIGEST, TAG
    if spoil == "bit":
        data[len(data) // 3] ^= 1
    elif spoil == "short":
        data = data[:len(data) // 2] + data[-200:]
    elif spoil == "digest":
        digest = "e" * 64
    elif spoil == "tag":
        tag = "optdesign-other"
    elif spoil == "empty":
        data = bytearray()
    path.write_bytes(bytes(data))
    if spoil == "writable":
        os.chmod(path, 0o622)
    assert user_cache.trusted(path, tag, digest) is None
    assert not user_cache.intact(path, tag, digest)


def test_a_link_is_not_followed_and_says_why(sealed, tmp_path, caplog):
    """A link planted under a kept file's name, even to a good file of the user's own
    (``--debug`` says why the file is passed over)."""
    path, _ = sealed
    link = tmp_path / "link.bin"
    link.symlink_to(path)
    with caplog.at_level(logging.DEBUG, logger="optdesign.cache"):
        assert user_cache.trusted(link, TAG, DIGEST) is None
        assert not user_cache.intact(link, TAG, DIGEST)
    assert caplog.messages == [f"{link} is a link: ignored"] * 2


def test_a_pipe_is_refused_without_waiting_for_a_writer(tmp_path, caplog):
    pipe = tmp_path / "pipe.bin"
    os.mkfifo(pipe, 0o600)
    answers = []
    thread = threading.Thread(target=lambda: answers.extend(
        [user_cache.intact(pipe, TAG, DIGEST), user_cache.trusted(pipe, TAG, DIGEST)]),
        daemon=True)
    with caplog.at_level(logging.DEBUG, logger="optdesign.cache"):
        thread.start()
        thread.join(10)
    assert answers == [False, None]
    assert caplog.messages == [f"{pipe} is not a regular file: ignored"] * 2


def test_a_missing_file_is_refused(tmp_path):
    assert user_cache.trusted(tmp_path / "none", TAG, DIGEST) is None
    assert not user_cache.intact(tmp_path / "none", TAG, DIGEST)


def test_a_file_checked_once_is_not_checked_again_until_it_changes(sealed, monkeypatch):
    """A check that passed leaves a note of the file's version beside it; a later check of
    the same version reads no checksum, and any change to the file (a bit flipped in place
    with its modification time put back, the file replaced by a copy) is checked again."""
    path, body = sealed
    note = path.with_name(path.name + user_cache.CHECKED)
    assert user_cache.intact(path, TAG, DIGEST) and note.is_file()
    sums = []
    trailer = user_cache.trailer
    monkeypatch.setattr(user_cache, "trailer", lambda *a: sums.append(1) or trailer(*a))
    assert user_cache.intact(path, TAG, DIGEST) and sums == []         # the note read
    assert not user_cache.intact(path, TAG, "e" * 64)                   # not what it names
    st = path.stat()
    with open(path, "r+b") as f:                                        # one bit, in place
        f.seek(len(body) // 3)
        byte = f.read(1)
        f.seek(len(body) // 3)
        f.write(bytes([byte[0] ^ 1]))
    os.utime(path, ns=(st.st_atime_ns, st.st_mtime_ns))
    assert path.stat().st_mtime_ns == st.st_mtime_ns
    assert not user_cache.intact(path, TAG, DIGEST) and sums
    user_cache.keep(path, TAG, DIGEST, body)                            # replaced whole
    assert user_cache.intact(path, TAG, DIGEST)


def test_a_note_others_may_write_or_a_link_is_not_read(sealed, tmp_path):
    path, _ = sealed
    note = path.with_name(path.name + user_cache.CHECKED)
    assert user_cache.intact(path, TAG, DIGEST)
    text = note.read_text()
    os.chmod(note, 0o666)
    assert user_cache._read_note(path) is None
    note.unlink()
    (tmp_path / "elsewhere").write_text(text)
    note.symlink_to(tmp_path / "elsewhere")
    assert user_cache._read_note(path) is None
    assert user_cache.intact(path, TAG, DIGEST)       # checked again, its bytes read
    # the note written anew in the link's place: the link's target is left as it was
    assert not note.is_symlink() and note.read_text() == text
    assert (tmp_path / "elsewhere").read_text() == text

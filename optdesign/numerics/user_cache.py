"""The user's cache folder, and the files in it a process may trust.

What is costly to make and the same every time (an NLP's derivatives compiled to C,
:mod:`optdesign.solver.compiled`; the NumPy lanes' Python code, :mod:`optdesign.numerics.lanes`)
is kept in ``$XDG_CACHE_HOME/optdesign`` (else ``~/.cache/optdesign``), mode 0700. A file
there is read only when it is a regular file of this user's, not writable by group or others,
and ends in a trailer with a tag, the digest of what it was made from and the checksum of the
bytes before it: a corrupt, foreign or stale file is ignored (and made anew), never loaded.
A library's checksum is read once per version of the file (:func:`intact`: a note of the
version checked beside it). Files are written atomically.

``OPTDESIGN_COMPILE``: ``on`` (the default), ``load`` (read what is cached, start no
compiler: the test suite), ``off`` (nothing is read from the folder or written to it).
"""
from __future__ import annotations

import hashlib
import json
import logging
import mmap
import os
import stat
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path

#: on | load | off (see the module's text)
VARIABLE = "OPTDESIGN_COMPILE"
MODES = ("on", "load", "off")

log = logging.getLogger("optdesign.cache")


def mode(env=os.environ) -> str:
    """``OPTDESIGN_COMPILE`` (on, load or off); an unknown value is taken as off."""
    value = env.get(VARIABLE, "").strip().lower() or "on"
    if value not in MODES:
        log.debug("%s=%r is not one of %s: the virtual machine only", VARIABLE,
                  env[VARIABLE], ", ".join(MODES))
        return "off"
    return value


def folder(env=os.environ) -> Path | None:
    """The cache folder, created with mode 0700; None where it is not this user's own (or
    cannot be made). A folder of the user's own that others may enter is closed first."""
    base = env.get("XDG_CACHE_HOME", "")
    base = Path(base) if os.path.isabs(base) else Path.home() / ".cache"
    path = base / "optdesign"
    try:
        base.mkdir(parents=True, exist_ok=True)
        try:
            os.mkdir(path, 0o700)
        except FileExistsError:
            pass
        st = os.lstat(path)
        if not stat.S_ISDIR(st.st_mode) or st.st_uid != os.getuid():
            log.debug("%s is not this user's folder: nothing cached is used", path)
            return None
        if st.st_mode & 0o077:
            os.chmod(path, 0o700)
    except OSError as exc:
        log.debug("no cache folder (%s)", exc)
        return None
    return path


def in_use(env=os.environ) -> Path | None:
    """The folder a process reads kept files from and writes them to: :func:`folder`, or
    None under ``OPTDESIGN_COMPILE=off``."""
    return None if mode(env) == "off" else folder(env)


def kept(where: Path | None, name: str, tag: str, digest: str) -> bytes | None:
    """The :func:`trusted` body of the file ``name`` in ``where``; None where there is no
    folder in use (:func:`in_use`), no such file, or a file not to be trusted."""
    return None if where is None else trusted(where / name, tag, digest)


def keep(path: Path, tag: str, digest: str, body: bytes) -> None:
    """``body`` into the cache as ``path``, sealed with its :func:`trailer`, atomically; a
    failure is logged and costs the next process the making alone."""
    try:
        write(path, body + trailer(tag, digest, body))
    except OSError as exc:
        log.debug("%s not kept (%s)", path.name, exc)


def read_record(name: str, tag: str, digest: str, layout: int) -> dict | None:
    """The JSON record kept as ``name`` in the folder in use (:func:`kept`, sealed with
    ``tag`` and ``digest``), or None: no folder, none kept, one not to be trusted, not to be
    read, or not of ``layout`` (its ``format``)."""
    body = kept(in_use(), name, tag, digest)
    if body is None:
        return None
    try:
        record = json.loads(body)
    except ValueError:
        return None
    return record if isinstance(record, dict) and record.get("format") == layout else None


def write_record(name: str, tag: str, digest: str, layout: int, record: dict) -> Path | None:
    """Keep ``record`` (with its ``format``, ``layout``) as ``name`` in the folder in use,
    atomically (:func:`keep`: a failure costs the next process the making alone); the
    folder, or None where there is none."""
    where = in_use()
    if where is None:
        return None
    body = json.dumps(record | {"format": layout}, separators=(",", ":")).encode()
    keep(where / name, tag, digest, body)
    return where


def let_go_of_old(where: Path, prefix: str, suffix: str, days: float, most: int) -> None:
    """Remove this user's regular files in ``where`` named ``prefix``...``suffix`` (records
    a later process may read, each named by the code that wrote it: every change of the
    code names new ones) written more than ``days`` ago, and the oldest beyond ``most``;
    nothing else is touched, no link followed."""
    oldest = time.time() - days * 86400.0
    try:
        entries = [e for e in os.scandir(where)
                   if e.name.startswith(prefix) and e.name.endswith(suffix)]
    except OSError:
        return
    records = []
    for entry in entries:
        try:
            st = entry.stat(follow_symlinks=False)
        except OSError:
            continue
        if stat.S_ISREG(st.st_mode) and st.st_uid == os.getuid():
            records.append((st.st_mtime, entry.path))
    records.sort(reverse=True)                  # the newest first
    for k, (written, path) in enumerate(records):
        if k >= most or written < oldest:
            try:
                os.unlink(path)
            except OSError:
                continue


def trailer(tag: str, digest: str, body: bytes) -> bytes:
    """What a cached file carries after its last byte: its tag, the digest of what it was
    made from and the checksum of ``body``, the bytes before it."""
    return f"\n{tag} {digest} {hashlib.sha256(body).hexdigest()}\n".encode()


def trailer_bytes(tag: str) -> int:
    """The length of a :func:`trailer` with ``tag`` (a sha256 digest and checksum)."""
    return len(tag) + 2 * 64 + 4


def trusted(path: Path, tag: str, digest: str) -> bytes | None:
    """The bytes of ``path`` before its trailer, or None: missing, not a regular file of
    this user's, writable by group or others, cut short or changed since it was written (its
    trailer's checksum), or made from something else (its trailer's digest)."""
    with _sealed(path, tag, digest) as body:
        return None if body is None else bytes(body)


def intact(path: Path, tag: str, digest: str) -> bool:
    """Whether ``path`` is to be trusted (:func:`trusted`), its bytes checked where they lie
    (mapped, not read into memory: a compiled library is megabytes). The checksum is read
    once per version of the file: a check that passes leaves a note beside it
    (:func:`_checked_note`: its device, inode, size, modification and change times), and a
    file that still has the very same ones is the file checked (any write to it, a copy or a
    rename over it changes one, and no user can set a change time back). That spares every
    later process the checksum of a library (megabytes for an NLP's)."""
    with _opened(path) as opened:
        if opened is None:
            return False
        note = _checked_note(opened[1], tag, digest)
        if _read_note(path) == note:
            return True
        with _body(*opened, path, tag, digest) as body:
            if body is None:
                return False
    try:
        write(_note_path(path), note.encode())
    except OSError as exc:
        log.debug("%s: no note of its check (%s)", path.name, exc)
    return True


#: the suffix of the note a check that passed leaves beside a file (:func:`intact`)
CHECKED = ".checked"


def _note_path(path: Path) -> Path:
    return path.with_name(path.name + CHECKED)


def _checked_note(st: os.stat_result, tag: str, digest: str) -> str:
    """What names the version of a file whose check passed: its tag and digest, and its
    device, inode, size, modification and change times."""
    return (f"{tag} {digest} {st.st_dev} {st.st_ino} {st.st_size} {st.st_mtime_ns} "
            f"{st.st_ctime_ns}\n")


def _read_note(path: Path) -> str | None:
    """The note beside ``path`` (:func:`intact`), where it is one to trust (a regular file
    of this user's that others may not write, not a link)."""
    with _opened(_note_path(path), quiet=True) as opened:
        if opened is None or opened[1].st_size > 1024:
            return None
        try:
            return os.read(opened[0], 1024).decode()
        except (OSError, UnicodeDecodeError):
            return None


@contextmanager
def _opened(path: Path, quiet: bool = False):
    """Inside, (descriptor, status) of the file ``path``, opened read-only without following
    a link or waiting on a pipe, then asked what it is (the file checked is the file read);
    None where it is missing or not to be trusted: not a regular file of this user's, or one
    others may write (``quiet``: said in no debug line)."""
    say = (lambda *args: None) if quiet else log.debug
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC)
    except FileNotFoundError:
        yield None
        return
    except OSError as exc:          # a link (ELOOP), or a file this user may not read
        say("%s is %s: ignored", path, "a link" if os.path.islink(path)
            else f"not to be opened ({exc.strerror})")
        yield None
        return
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            say("%s is not a regular file: ignored", path)
            yield None
        elif st.st_uid != os.getuid() or st.st_mode & 0o022:
            say("%s is not this user's own or others may write it: ignored", path)
            yield None
        else:
            yield fd, st
    finally:
        os.close(fd)


@contextmanager
def _sealed(path: Path, tag: str, digest: str):
    """Inside, a view of the bytes of ``path`` before its trailer (the file mapped, read
    only), or None where it is not to be trusted (:func:`trusted`)."""
    with _opened(path) as opened:
        if opened is None:
            yield None
            return
        with _body(*opened, path, tag, digest) as body:
            yield body


@contextmanager
def _body(fd: int, st: os.stat_result, path: Path, tag: str, digest: str):
    """Inside, a view of the bytes before its trailer of the file opened as ``fd`` (status
    ``st``, :func:`_opened`), or None where the trailer does not seal them with ``tag`` and
    ``digest``. (A file cut short in place while it is mapped would fault the process, as
    would the library CasADi maps after the check: the cache's files are only ever replaced
    whole, by a rename, which leaves a mapped file as it was.)"""
    size = trailer_bytes(tag)
    if st.st_size > size:
        with mmap.mmap(fd, 0, access=mmap.ACCESS_READ) as mapped, \
                memoryview(mapped) as whole, whole[:-size] as body, whole[-size:] as end:
            if end == trailer(tag, digest, body):
                yield body
                return
    log.debug("%s is corrupt or was made from something else: ignored", path)
    yield None


def write(path: Path, data: bytes, keep: bool = False) -> Path:
    """``data`` into ``path`` atomically (a temporary file of this user's, mode 0600,
    renamed); with ``keep``, into the temporary file of a name of its own alone, returned."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        if not keep:
            os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return Path(tmp) if keep else path

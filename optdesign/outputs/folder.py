"""An output folder that holds the files of one run only, whatever kills the run.

* **One run at a time.** :class:`OutputFolder` takes an exclusive ``flock`` on ``.NAME.lock``
  beside the folder ``NAME`` (in its parent: the folder itself may be replaced, the lock must
  outlive it). A second run on the same folder is refused at once (exit 2, naming the first
  run's pid); the kernel drops the lock when its holder exits or dies, so a killed run never
  blocks the next one.
* **One run's set.** :meth:`OutputFolder.replace_with` has the command write its whole set into
  a fresh hidden sibling ``.NAME.new-TOKEN``; only then does the set go in:

  - a folder that holds nothing but the command's own files (the usual ``results/NAME/``) is
    exchanged with the sibling in one ``renameat2(RENAME_EXCHANGE)`` (Linux; elsewhere two
    renames, rolled back by the next run if a kill falls between them). A kill before the
    exchange leaves the old set, after it the new one, never a mix;
  - a folder that also holds files of the user's is never moved: the complete set is marked
    for commit (``.NAME.commit-TOKEN``) and its files are renamed in one by one (microseconds);
    should a kill fall in between, the next run that claims the folder completes the commit
    before anything else.
* **No litter.** What a killed run left (a sibling being written, the old set being removed,
  the hidden ``.FILE.*.tmp`` files of :mod:`optdesign.outputs.atomic`) is removed by the next run that
  claims the folder, before it writes anything. A file that is not one of the command's is
  never removed: found in a sibling, it is moved back into the folder.

A command whose files grow while it runs (``pareto``'s journal) writes in place under the same
lock, and clears the previous run's set first (:meth:`OutputFolder.remove_owned`).

**Nothing beside the folder is trusted.** The parent may be shared (``/tmp``), so anything
found there under our names may have been planted: the lock is opened without following a
link and is refused unless it is a plain file of ours holding at most a pid (never truncated
otherwise), and it is removed when the run ends; a leftover sibling is touched only if it is a
real folder (not a link) of this user, a commit's manifest only if it names plain names of the
command's own set (anything else: the leftover is left as it is, with a word on stderr, and
nothing is deleted or moved); only regular files are ever moved in; a replaced folder keeps
its owner, group, mode and extended attributes (:mod:`optdesign.outputs.attributes`), and a
folder whose attributes the run cannot give its sibling is written into in place; a link on
the way to the folder is followed only as the kernel's protected-symlinks rule allows
(:mod:`optdesign.outputs.links`).
"""
from __future__ import annotations

import errno
import json
import os
import secrets
import shutil
import stat
import sys
from pathlib import Path
from typing import Callable, Iterable

from optdesign.errors import ProblemError
from optdesign.outputs.atomic import atomic_write_json
from optdesign.outputs.attributes import take_on
from optdesign.outputs.links import followed
from optdesign.outputs.provenance import SOURCE, record

#: in a set marked for commit: the names its command owns
MARKER = ".optdesign-set.json"
_NEW, _OLD, _COMMIT = "new", "old", "commit"

#: how long a second run waits for the lock before refusing (workers of a run killed a
#: moment ago release it as they die)
LOCK_GRACE_S = 2.0


class OutputFolder:
    """A command's output folder, held exclusively between ``__enter__`` and ``__exit__``.

    Parameters
    ----------
    path : path
        The folder, as the user named it (messages quote it so).
    owned : iterable of str
        The names of every file the command may write there; anything else is the user's.
    source : path, optional
        The problem file the run's results come from: recorded in its set
        (:mod:`optdesign.outputs.provenance`); without it the folder's record is kept.
    """

    def __init__(self, path: str | Path, owned: Iterable[str], source=None):
        self.shown = Path(path)
        # a planted link is refused here too, not only by the check before the work: the
        # folder is claimed minutes later, and may be replaced as a whole
        self.path = Path(followed(path, str(path)))
        # the record of the problem file the results came from goes with every set
        self.owned = frozenset(owned) | {SOURCE}
        self.source = source
        self._lock_fd: int | None = None

    # ------------------------------------------------------------------ lock
    def __enter__(self) -> "OutputFolder":
        self.acquire()
        return self

    def __exit__(self, *exc) -> None:
        self.release()

    def acquire(self) -> None:
        """Take the folder's lock (refused with :class:`ProblemError` if another run holds
        it, or if the lock's name holds anything but a lock of ours), then clean up after any
        run that was killed there."""
        if not self.path.name:
            raise ProblemError(f"{self.shown}: cannot write into the root folder")
        if self.path.exists() and not self.path.is_dir():
            raise ProblemError(f"{self.shown}: is a file, not a folder")
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise ProblemError(f"{self.shown}: cannot create its parent folder "
                               f"({exc.strerror})") from None
        self._lock_fd = self._take_lock(self._sibling("lock"))
        try:
            self._recover()
        except BaseException:           # refused, or a kill: the lock is not left behind
            self.release()
            raise

    def _take_lock(self, lock: Path) -> int:
        """The open, flocked and pid-stamped lock file: opened without following a link,
        checked to be a plain file of ours before a byte of it is written, and re-opened when
        the run that held it removed it meanwhile."""
        while True:
            try:
                fd = os.open(lock, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_NONBLOCK
                             | os.O_CLOEXEC, 0o600)
            except OSError as exc:
                why = "it is a link" if exc.errno == errno.ELOOP else exc.strerror
                raise ProblemError(f"{self.shown}: cannot use the lock file {lock} ({why}); "
                                   f"remove it if no optdesign run is writing there") from None
            try:
                if not _is_our_lock(os.fstat(fd)):
                    raise ProblemError(
                        f"{self.shown}: {lock} is not an optdesign lock (not a plain file of "
                        f"yours holding a pid); it is left as it is: remove it or choose "
                        f"another --out")
                if not _try_lock(fd, grace_s=LOCK_GRACE_S):
                    holder = os.pread(fd, 32, 0).decode("ascii", "replace").strip()
                    who = f" (pid {holder})" if holder.isdigit() else ""
                    raise ProblemError(f"{self.shown}: another optdesign run{who} is writing "
                                       f"there; wait for it to finish or choose another --out")
                if not _same_file(fd, lock):        # its holder removed it as we waited
                    os.close(fd)
                    continue
                os.ftruncate(fd, 0)                 # our own lock: a pid at most
                os.pwrite(fd, f"{os.getpid()}\n".encode("ascii"), 0)
                return fd
            except BaseException:
                _close_quietly(fd)
                raise

    def release(self) -> None:
        """Remove the lock file (still holding it, so no other run can hold the name), then
        drop the lock."""
        if self._lock_fd is not None:
            lock = self._sibling("lock")
            if _same_file(self._lock_fd, lock):
                lock.unlink(missing_ok=True)
            os.close(self._lock_fd)       # closing drops the flock
            self._lock_fd = None

    # ------------------------------------------------------------------ writing
    def replace_with(self, write: Callable[[Path], list[Path]]) -> list[Path]:
        """Call ``write(folder)`` on a fresh sibling folder, then put the set it wrote in
        place of the previous one; returns the written files' paths as the user sees them."""
        self._require_lock()
        token = f"{os.getpid()}-{secrets.token_hex(3)}"
        staging = self._sibling(f"{_NEW}-{token}")
        staging.mkdir()
        try:
            # the set keeps the folder's owner, group, mode and extended attributes; where
            # the sibling cannot be given them, it is committed into the folder instead
            kept = take_on(self.path, staging) if self.path.is_dir() else True
            if self.source is not None:
                record(staging, self.source)
            elif _is_regular(self.path / SOURCE):
                shutil.copyfile(self.path / SOURCE, staging / SOURCE)
            written = write(staging)
            _fsync_dir(staging)
            if kept and self._holds_only_owned() and not self._holds_working_folder():
                self._exchange_in(staging, token)
            else:
                self._commit_in_place(staging, token)
        except BaseException as exc:
            if staging.exists():
                shutil.rmtree(staging, ignore_errors=True)
            if isinstance(exc, OSError) and isinstance(exc.filename, str) and \
                    Path(exc.filename).is_relative_to(staging):   # named as the user sees it
                raise OSError(exc.errno, exc.strerror, str(
                    self.shown / Path(exc.filename).relative_to(staging))) from None
            raise
        return [self.shown / Path(p).relative_to(staging) for p in written]

    def remove_owned(self) -> None:
        """Remove the previous run's files (every owned name), for a command that writes in
        place; the user's files stay."""
        self._require_lock()
        for name in self.owned - {SOURCE}:
            (self.path / name).unlink(missing_ok=True)
        if self.source is not None:
            record(self.path, self.source)

    # ------------------------------------------------------------------ steps
    def _exchange_in(self, staging: Path, token: str) -> None:
        if not self.path.exists():
            os.rename(staging, self.path)
        elif _exchange(staging, self.path):
            self._discard(staging)                       # now the previous set
        else:                                            # no atomic exchange: two renames
            old = self._sibling(f"{_OLD}-{token}")
            os.rename(self.path, old)
            os.rename(staging, self.path)
            self._discard(old)
        _fsync_dir(self.path.parent)

    def _commit_in_place(self, staging: Path, token: str) -> None:
        files = sorted(p.name for p in staging.iterdir())
        if not set(files) <= self.owned:
            raise RuntimeError(f"the command wrote files it does not own: "
                               f"{sorted(set(files) - self.owned)}")
        atomic_write_json(staging / MARKER, {"owned": sorted(self.owned), "files": files})
        commit = self._sibling(f"{_COMMIT}-{token}")
        os.rename(staging, commit)                        # the commit point
        self._finish_commit(commit)

    def _finish_commit(self, commit: Path) -> None:
        """Rename a committed set's files into the folder (those a kill left), remove the
        owned files the set lacks. A manifest that names anything but plain names of this
        command's set is not ours: the leftover stays as it is and nothing is touched."""
        marker = _manifest(commit / MARKER, self.owned)
        if marker is None:
            _leave(commit, "its manifest is not optdesign's")
            return
        owned, files = marker
        self.path.mkdir(parents=True, exist_ok=True)
        for name in sorted(files):
            entry = commit / name
            if _is_regular(entry):
                os.replace(entry, self.path / name)
        for name in sorted(owned - files):
            (self.path / name).unlink(missing_ok=True)
        _fsync_dir(self.path)
        shutil.rmtree(commit, ignore_errors=True)

    def _recover(self) -> None:
        """Undo or complete what a killed run left beside and in the folder. Only a real
        folder of this user counts as a leftover; a link or another user's entry is left."""
        name = self.path.name
        for kind in (_OLD, _COMMIT, _NEW):
            prefix = f".{name}.{kind}-"
            leftovers = sorted(p for p in self.path.parent.iterdir()
                               if p.name.startswith(prefix))
            for leftover in leftovers:
                if not _is_own_folder(leftover):
                    _leave(leftover, "it is not a folder of this user's")
                elif kind == _OLD and not self.path.exists():
                    os.rename(leftover, self.path)       # killed between the two renames
                elif kind == _COMMIT and (leftover / MARKER).exists():
                    self._finish_commit(leftover)
                else:
                    self._discard(leftover)
        if self.path.is_dir():
            for entry in self.path.iterdir():
                if not _is_temporary(entry.name, self.owned):
                    continue
                if entry.is_dir() and not entry.is_symlink():     # never one of ours
                    raise ProblemError(f"{self.shown / entry.name}: is a folder where "
                                       f"optdesign keeps a temporary file; remove it or "
                                       f"choose another --out")
                entry.unlink(missing_ok=True)

    def _discard(self, folder: Path) -> None:
        """Remove a sibling holding an old or unfinished set; a regular file in it that is
        not ours is moved back into the folder (or, if the folder has one of that name, or it
        is anything but a regular file, the sibling is left there)."""
        keep = False
        for entry in list(folder.iterdir()):
            if entry.name in self.owned or entry.name == MARKER or \
                    _is_temporary(entry.name, self.owned):
                continue
            target = self.path / entry.name
            if _is_regular(entry) and self.path.is_dir() and not os.path.lexists(target):
                os.rename(entry, target)
            else:
                keep = True
        if keep:
            _leave(folder, "it holds files that are not optdesign's")
            return
        shutil.rmtree(folder, ignore_errors=True)

    def _holds_only_owned(self) -> bool:
        if not self.path.exists():
            return True
        return all(e.name in self.owned or _is_temporary(e.name, self.owned)
                   for e in self.path.iterdir())

    def _holds_working_folder(self) -> bool:
        """True when this process works inside the folder: replacing it would leave the
        shell that started us in a deleted folder."""
        try:
            cwd = Path(os.getcwd())
        except OSError:
            return False
        return cwd == self.path or self.path in cwd.parents

    def _sibling(self, kind: str) -> Path:
        return self.path.parent / f".{self.path.name}.{kind}"

    def _require_lock(self) -> None:
        if self._lock_fd is None:
            raise RuntimeError("OutputFolder used without holding its lock")


def _is_our_lock(st: os.stat_result) -> bool:
    """A lock file of ours: a regular file with no other name (a hard link to a user's file
    would be truncated), of this user, holding at most a pid line."""
    return (stat.S_ISREG(st.st_mode) and st.st_nlink == 1 and st.st_size <= 32
            and st.st_uid == os.geteuid())


def _same_file(fd: int, path: Path) -> bool:
    """True while ``path`` (not followed) still names the file open as ``fd``."""
    try:
        here, there = os.fstat(fd), os.lstat(path)
    except OSError:
        return False
    return (here.st_dev, here.st_ino) == (there.st_dev, there.st_ino)


def _close_quietly(fd: int) -> None:
    try:
        os.close(fd)
    except OSError:
        pass


def write_set(out: str | Path, owned: Iterable[str], write: Callable[[Path], list[Path]]
              ) -> list[Path]:
    """``write(folder)`` into a fresh folder, whose set then replaces the previous one of
    ``out`` whole (:meth:`OutputFolder.replace_with`, one run at a time in ``out``): a
    command that fails half-way (a disk full) leaves the earlier set as it was."""
    with OutputFolder(out, owned) as folder:
        return folder.replace_with(write)


def _is_own_folder(path: Path) -> bool:
    """A real folder (not a link to one) of this user."""
    try:
        st = os.lstat(path)
    except OSError:
        return False
    return stat.S_ISDIR(st.st_mode) and st.st_uid == os.geteuid()


def _is_regular(path: Path) -> bool:
    """A regular file (not a link, a folder, a pipe or a device)."""
    try:
        return stat.S_ISREG(os.lstat(path).st_mode)
    except OSError:
        return False


def _is_plain_name(name) -> bool:
    """One file name: a non-empty string without a separator, not ``.`` or ``..``."""
    return (isinstance(name, str) and name not in ("", ".", "..") and "/" not in name
            and "\0" not in name and (os.altsep is None or os.altsep not in name))


def _manifest(path: Path, command_owns: frozenset) -> tuple[set, set] | None:
    """(owned, files) of a commit's manifest, or None when it is not one of ours: unreadable,
    not a regular file, or naming anything but plain names of the command's own set."""
    if not _is_regular(path) or path.stat().st_size > 1 << 16:
        return None
    try:
        marker = json.loads(path.read_text(encoding="utf-8"))
        owned, files = marker["owned"], marker["files"]
    except (OSError, ValueError, TypeError, KeyError):
        return None
    if not (isinstance(owned, list) and isinstance(files, list)):
        return None
    names = owned + files
    if not all(_is_plain_name(n) and n in command_owns for n in names):
        return None
    return set(owned), set(files)


def _leave(path: Path, why: str) -> None:
    print(f"optdesign: left {path} in place: {why}", file=sys.stderr)


def _is_temporary(name: str, owned) -> bool:
    """A hidden temporary of :func:`optdesign.outputs.atomic.atomic_write_bytes` for an owned file."""
    return name.startswith(".") and name.endswith(".tmp") and any(
        name.startswith(f".{o}.") for o in owned)


def _try_lock(fd: int, grace_s: float = 0.0) -> bool:
    """The exclusive flock, tried for ``grace_s`` seconds: a run killed a moment ago may
    still have forked workers on their way out, which hold the lock until they are gone."""
    try:
        import fcntl
    except ImportError:                 # pragma: no cover - no flock (Windows): no lock
        return True
    import time
    deadline = time.monotonic() + grace_s
    while True:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            return True
        except BlockingIOError:
            if time.monotonic() >= deadline:
                return False
            time.sleep(0.1)


def _exchange(a: Path, b: Path) -> bool:
    """Swap two paths atomically (Linux ``renameat2``); False where that is not available."""
    if not sys.platform.startswith("linux"):
        return False
    import ctypes
    libc = ctypes.CDLL(None, use_errno=True)
    renameat2 = getattr(libc, "renameat2", None)
    if renameat2 is None:
        return False
    at_fdcwd, rename_exchange = -100, 2
    if renameat2(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), rename_exchange) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.EINVAL, errno.ENOSYS, errno.EOPNOTSUPP, errno.ENOTSUP):
        return False
    raise OSError(err, os.strerror(err), str(b))


def _fsync_dir(path: Path) -> None:
    """Make a folder's renames durable (a no-op where folders cannot be opened)."""
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)

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
  the hidden ``.FILE.*.tmp`` files of :mod:`optdesign.io`) is removed by the next run that
  claims the folder, before it writes anything. A file that is not one of the command's is
  never removed: found in a sibling, it is moved back into the folder.

A command whose files grow while it runs (``pareto``'s journal) writes in place under the same
lock, and clears the previous run's set first (:meth:`OutputFolder.remove_owned`).
"""
from __future__ import annotations

import errno
import json
import os
import secrets
import shutil
import sys
from pathlib import Path
from typing import Callable, Iterable

from .errors import ProblemError
from .io import atomic_write_json

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
    """

    def __init__(self, path: str | Path, owned: Iterable[str]):
        self.shown = Path(path)
        self.path = Path(os.path.realpath(path))
        self.owned = frozenset(owned)
        self._lock_fd: int | None = None

    # ------------------------------------------------------------------ lock
    def __enter__(self) -> "OutputFolder":
        self.acquire()
        return self

    def __exit__(self, *exc) -> None:
        self.release()

    def acquire(self) -> None:
        """Take the folder's lock (refused with :class:`ProblemError` if another run holds
        it), then clean up after any run that was killed there."""
        if not self.path.name:
            raise ProblemError(f"{self.shown}: cannot write into the root folder")
        if self.path.exists() and not self.path.is_dir():
            raise ProblemError(f"{self.shown}: is a file, not a folder")
        lock = self._sibling("lock")
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as exc:
            raise ProblemError(f"{self.shown}: cannot create the lock file {lock} "
                               f"({exc.strerror})") from None
        if not _try_lock(fd, grace_s=LOCK_GRACE_S):
            os.lseek(fd, 0, os.SEEK_SET)
            holder = os.read(fd, 32).decode("ascii", "replace").strip()
            os.close(fd)
            who = f" (pid {holder})" if holder.isdigit() else ""
            raise ProblemError(f"{self.shown}: another optdesign run{who} is writing there; "
                               f"wait for it to finish or choose another --out")
        os.ftruncate(fd, 0)
        os.lseek(fd, 0, os.SEEK_SET)
        os.write(fd, f"{os.getpid()}\n".encode("ascii"))
        self._lock_fd = fd
        self._recover()

    def release(self) -> None:
        if self._lock_fd is not None:
            os.ftruncate(self._lock_fd, 0)
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
            written = write(staging)
            _fsync_dir(staging)
            if self._holds_only_owned() and not self._holds_working_folder():
                self._exchange_in(staging, token)
            else:
                self._commit_in_place(staging, token)
        except BaseException:
            if staging.exists():
                shutil.rmtree(staging, ignore_errors=True)
            raise
        return [self.shown / Path(p).relative_to(staging) for p in written]

    def remove_owned(self) -> None:
        """Remove the previous run's files (every owned name), for a command that writes in
        place; the user's files stay."""
        self._require_lock()
        for name in self.owned:
            (self.path / name).unlink(missing_ok=True)

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
        atomic_write_json(staging / MARKER, {"owned": sorted(self.owned),
                                             "files": sorted(p.name for p in staging.iterdir())})
        commit = self._sibling(f"{_COMMIT}-{token}")
        os.rename(staging, commit)                        # the commit point
        self._finish_commit(commit)

    def _finish_commit(self, commit: Path) -> None:
        """Rename a committed set's files into the folder (those a kill left), remove the
        owned files the set lacks."""
        marker = json.loads((commit / MARKER).read_text())
        owned, files = set(marker["owned"]), set(marker["files"])
        self.path.mkdir(parents=True, exist_ok=True)
        for name in sorted(p.name for p in commit.iterdir() if p.name in files):
            os.replace(commit / name, self.path / name)
        for name in sorted(owned - files):
            (self.path / name).unlink(missing_ok=True)
        _fsync_dir(self.path)
        shutil.rmtree(commit, ignore_errors=True)

    def _recover(self) -> None:
        """Undo or complete what a killed run left beside and in the folder."""
        name = self.path.name
        for kind in (_OLD, _COMMIT, _NEW):
            for leftover in sorted(self.path.parent.glob(f".{name}.{kind}-*")):
                if kind == _OLD and not self.path.exists():
                    os.rename(leftover, self.path)       # killed between the two renames
                elif kind == _COMMIT and (leftover / MARKER).exists():
                    self._finish_commit(leftover)
                else:
                    self._discard(leftover)
        if self.path.is_dir():
            for entry in self.path.iterdir():
                if _is_temporary(entry.name, self.owned):
                    entry.unlink(missing_ok=True)

    def _discard(self, folder: Path) -> None:
        """Remove a sibling holding an old or unfinished set; an entry that is not ours is
        moved back into the folder (or, if the folder has one of that name, left there)."""
        keep = False
        for entry in list(folder.iterdir()):
            if entry.name in self.owned or entry.name == MARKER or \
                    _is_temporary(entry.name, self.owned):
                continue
            target = self.path / entry.name
            if self.path.is_dir() and not target.exists():
                os.rename(entry, target)
            else:
                keep = True
        if keep:
            print(f"optdesign: left {folder} in place: it holds files that are not "
                  f"optdesign's", file=sys.stderr)
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


def _is_temporary(name: str, owned) -> bool:
    """A hidden temporary of :func:`optdesign.io.atomic_write_bytes` for an owned file."""
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

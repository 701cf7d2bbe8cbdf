"""Figures drawn beside the command, off the path of its answer.

A figure costs a command the import of matplotlib (half a second) and its drawing (up to a
second for a linkage with its labels and thumbnails), all of it after the answer is known.
A command that draws opens a :class:`FigureProcess` as soon as it has read its problem file:
a forked process imports matplotlib and draws a first small figure (the fonts) while the
command computes, then waits. Once the answer is written and printed, the command hands it
its figures (:meth:`FigureProcess.draw`, each a module-level function and its arguments) and
goes on with its own work; the process draws them all at once, each but the last in a
process forked from the warm one. :meth:`FigureProcess.wait` returns what each figure's
function returned, in order, or raises the first error a figure met as it was raised there:
an ``OSError`` stays an ``OSError``, so the command's one line on stderr and its exit code
are those of a figure drawn in the command itself (``--debug`` shows the figure's traceback
as a note of the exception).

Every process of it dies with the command (:func:`optdesign.lifetime.die_with_parent`, even on
``kill -9``), ignores Ctrl-C (the command ends it), and writes only where its figures write:
into the command's output set, whose rules stay those of :mod:`optdesign.outputs.folder` (a
killed run's half-drawn figure is a temporary in the set's hidden sibling, removed by the next
run). Leaving the ``with`` block ends whatever of it still runs, at once. Where the platform
cannot fork, or with ``enabled=False``, :meth:`wait` draws the figures in the command, one
after another.
"""
from __future__ import annotations

import os
import pickle
import signal
import struct
import sys
import traceback
from typing import Any, Callable, Sequence

from optdesign.errors import OptDesignError
from optdesign.lifetime import die_with_parent, signals_held

#: one figure: a module-level function (a forked process finds it by name), its arguments
Job = tuple  # (Callable, tuple, dict)
_LENGTH = struct.Struct("!Q")
_beside: list[bool] = []             # [True] in a process forked to draw


def in_figures_process() -> bool:
    """True in a process a :class:`FigureProcess` forked to draw figures: one that may fork
    again (it runs no thread of the command's), e.g. to render one figure in two halves
    (:mod:`optdesign.outputs.split_figure`)."""
    return bool(_beside)


class FigureProcess:
    """The process that draws a command's figures (see the module's text).

    Parameters
    ----------
    enabled : bool
        False draws nothing beside: :meth:`wait` draws the figures in this process.
    warm : callable, optional
        Run in the forked process before it waits (e.g.
        :func:`optdesign.figures.design.warm_up`); its failure is left to the figures.
    """

    def __init__(self, enabled: bool = True, warm: Callable[[], Any] | None = None):
        self._pid: int | None = None
        self._jobs_w: int | None = None
        self._results_r: int | None = None
        self._sent = False
        self._inline: list[Job] = []
        if enabled and hasattr(os, "fork"):
            self._start(warm)

    def __enter__(self) -> "FigureProcess":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # ------------------------------------------------------------------ the command's side
    def draw(self, jobs: Sequence[Job]) -> None:
        """Start drawing ``jobs`` (``(function, args)`` or ``(function, args, kwargs)``)."""
        jobs = [(j[0], tuple(j[1]), dict(j[2]) if len(j) > 2 else {}) for j in jobs]
        if self._pid is None or not jobs:
            self._inline.extend(jobs)
            return
        try:
            _send(self._jobs_w, jobs)
            self._sent = True
        except (OSError, pickle.PicklingError, TypeError, AttributeError):
            self._stop()                        # the process is gone, or a job does not
            self._inline.extend(jobs)           # pickle: drawn here instead

    def wait(self) -> list:
        """What each figure's function returned, in the order given to :meth:`draw`."""
        out = []
        if self._sent:
            self._sent = False
            outcomes = _receive(self._results_r)
            self._reap()
            if outcomes is None:
                raise OptDesignError("the process drawing the figures ended before it "
                                     "finished (killed, or out of memory?)")
            for outcome in outcomes:
                if outcome[0] == "error":
                    raise _annotated(outcome[1], outcome[2])
                out.append(outcome[1])
        jobs, self._inline = self._inline, []
        return out + [function(*args, **kwargs) for function, args, kwargs in jobs]

    def close(self) -> None:
        """End the process (at once, whatever it is doing) and reap it."""
        self._stop()

    # ------------------------------------------------------------------ steps
    def _start(self, warm) -> None:
        jobs_r, jobs_w = os.pipe()
        results_r, results_w = os.pipe()
        parent = os.getpid()
        for stream in (sys.stdout, sys.stderr):     # nothing buffered is written twice
            try:
                stream.flush()
            except (OSError, ValueError, AttributeError):
                pass
        with signals_held():                        # a Ctrl-C now is not lost
            pid = os.fork()
            if pid == 0:                            # the figures' process: never returns
                try:
                    os.close(jobs_w)
                    os.close(results_r)
                    die_with_parent(parent)         # its own handlers: Ctrl-C ignored
                    _serve(jobs_r, results_w, warm)
                finally:
                    os._exit(0)
        os.close(jobs_r)
        os.close(results_w)
        self._pid, self._jobs_w, self._results_r = pid, jobs_w, results_r

    def _stop(self) -> None:
        for fd in (self._jobs_w, self._results_r):
            if fd is not None:
                try:
                    os.close(fd)
                except OSError:
                    pass
        self._jobs_w = self._results_r = None
        if self._pid is not None:
            try:
                os.kill(self._pid, signal.SIGKILL)      # its own children die with it
            except ProcessLookupError:
                pass
            self._reap()
        self._sent = False

    def _reap(self) -> None:
        if self._pid is not None:
            try:
                os.waitpid(self._pid, 0)
            except ChildProcessError:
                pass
            self._pid = None


# ---------------------------------------------------------------------- the forked side
def _serve(jobs_r: int, results_w: int, warm) -> None:
    """Warm up, wait for the jobs, draw them (each but the last in a process of its own),
    send back every outcome."""
    _beside.append(True)
    if warm is not None:
        try:
            warm()
        except Exception:               # the figure that needs it will say what is wrong
            pass
    jobs = _receive(jobs_r)
    if not jobs:
        return
    helpers = [_fork_job(job, (jobs_r, results_w)) for job in jobs[:-1]]
    last = _outcome(jobs[-1])
    outcomes = []
    for pid, fd in helpers:
        got = _receive(fd)
        os.close(fd)
        _, status = os.waitpid(pid, 0)
        outcomes.append(got[0] if got else
                        ("error", OptDesignError(f"the process drawing a figure ended before "
                                                 f"it finished (wait status {status})"), ""))
    _send(results_w, [_sendable(o) for o in outcomes + [last]])


def _fork_job(job: Job, close: tuple[int, ...]) -> tuple[int, int]:
    """(pid, read end) of a process forked to draw ``job``."""
    read, write = os.pipe()
    parent = os.getpid()
    pid = os.fork()
    if pid == 0:
        try:
            os.close(read)
            for fd in close:
                os.close(fd)
            die_with_parent(parent)
            _send(write, [_sendable(_outcome(job))])
        finally:
            os._exit(0)
    os.close(write)
    return pid, read


def _outcome(job: Job) -> tuple:
    """("ok", what the function returned) or ("error", the exception, its traceback)."""
    function, args, kwargs = job
    try:
        return ("ok", function(*args, **kwargs))
    except BaseException as exc:            # noqa: BLE001 - every error goes to the command
        return ("error", exc, traceback.format_exc())


# ---------------------------------------------------------------------- messages
def _send(fd: int, value) -> None:
    """One pickled message, its length first."""
    data = pickle.dumps(value, protocol=pickle.HIGHEST_PROTOCOL)
    view = memoryview(_LENGTH.pack(len(data)) + data)
    while view:
        view = view[os.write(fd, view):]


def _sendable(outcome: tuple) -> tuple:
    """``outcome`` as it can cross to the command: an exception (or a value) that does not
    pickle becomes a RuntimeError naming its type and text."""
    try:
        pickle.dumps(outcome, protocol=pickle.HIGHEST_PROTOCOL)
        return outcome
    except Exception:                   # noqa: BLE001 - whatever pickling a value raises
        if outcome[0] == "error":
            exc = outcome[1]
            return ("error", RuntimeError(f"{type(exc).__name__}: {exc}"), outcome[2])
        return ("error", RuntimeError(f"a figure returned a {type(outcome[1]).__name__}, "
                                      f"which cannot be sent back"), "")


def _receive(fd: int):
    """The next message, or None when the pipe ends first."""
    head = _read(fd, _LENGTH.size)
    if head is None:
        return None
    body = _read(fd, _LENGTH.unpack(head)[0])
    return None if body is None else pickle.loads(body)


def _read(fd: int, n: int) -> bytes | None:
    chunks, left = [], n
    while left:
        chunk = os.read(fd, min(left, 1 << 20))
        if not chunk:
            return None
        chunks.append(chunk)
        left -= len(chunk)
    return b"".join(chunks)


def _annotated(exc: BaseException, where: str) -> BaseException:
    """The figure's exception with its traceback in the drawing process as a note."""
    if where and hasattr(exc, "add_note"):
        exc.add_note("raised while drawing a figure, in the process that draws them:\n"
                     + where.rstrip())
    return exc

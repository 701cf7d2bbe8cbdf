"""Child processes that die with their parent, and a SIGTERM that unwinds like Ctrl-C.

A worker process forked by a sweep or a solve must not outlive the command that started it:
killed with ``kill -9``, the parent runs no clean-up, and its workers would be reparented and
go on computing (or wait forever on a queue nobody writes to). Two guards, both in the child:

* on Linux, ``prctl(PR_SET_PDEATHSIG, SIGKILL)``: the kernel kills the child the moment its
  parent dies;
* elsewhere, a watchdog thread that ends the child once its parent's pid is no longer its
  parent (the child was reparented), within :data:`WATCH_INTERVAL_S`.

A SIGTERM to the parent is turned into ``SystemExit`` (:func:`exit_on_sigterm`), so ``finally``
blocks run: a pool terminates its workers and a half-written output set is removed, as on
Ctrl-C.
"""
from __future__ import annotations

import os
import signal
import sys
import threading
from contextlib import contextmanager

#: seconds between two checks of the watchdog
WATCH_INTERVAL_S = 0.5
_PR_SET_PDEATHSIG = 1


def die_with_parent(parent_pid: int | None = None) -> None:
    """Make this (child) process end when ``parent_pid`` (default: its parent now) dies,
    and at once on SIGTERM; it ignores SIGINT (its parent ends it).

    Usable as a ``ProcessPoolExecutor`` initializer: ``initializer=die_with_parent,
    initargs=(os.getpid(),)``.
    """
    parent_pid = parent_pid or os.getppid()
    try:        # not the parent's handler of :func:`exit_on_sigterm`: a worker just ends
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        # Ctrl-C reaches the whole process group: the parent unwinds and ends its workers;
        # a worker interrupted itself would print multiprocessing's "Process ForkProcess-1:"
        # and a traceback on stderr
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    except ValueError:                         # not the main thread: nothing inherited there
        pass
    by_kernel = _kill_me_when_parent_dies()
    if os.getppid() != parent_pid:             # the parent died before the guard was set
        os._exit(1)
    if not by_kernel:
        threading.Thread(target=_watch, args=(parent_pid,), name="die-with-parent",
                         daemon=True).start()


def _kill_me_when_parent_dies() -> bool:
    """Linux's ``prctl(PR_SET_PDEATHSIG, SIGKILL)``; False where there is none."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        import ctypes
        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


def _watch(parent_pid: int) -> None:
    import time
    while os.getppid() == parent_pid:
        time.sleep(WATCH_INTERVAL_S)
    os._exit(1)


class Terminated(SystemExit):
    """SIGTERM received: unwinds the stack like an exception, exits with 128 + 15."""


_terminated: list[int] = []          # the signal received inside exit_on_sigterm, if any


def raise_if_terminated() -> None:
    """Raise :class:`Terminated` again if a SIGTERM came: the handler's exception can land in
    a finaliser (``__del__``, a GC callback), where Python prints and drops it. Long loops
    call this, and nothing is published after a SIGTERM."""
    if _terminated:
        raise Terminated(128 + _terminated[0])


@contextmanager
def exit_on_sigterm():
    """While inside, a SIGTERM raises :class:`Terminated` in the main thread, and leaving
    the block normally after one raises it again (no-op when called from another thread,
    where Python cannot install signal handlers)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, frame):
        signal.signal(signal.SIGTERM, signal.SIG_DFL)     # a second SIGTERM ends at once
        _terminated.append(signum)
        print("optdesign: terminated", file=sys.stderr)
        raise Terminated(128 + signum)

    _terminated.clear()
    previous = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)
    raise_if_terminated()


def beside(fn, *args):
    """Start ``fn(*args)`` in a forked child (that dies with this process) and return a
    function that waits for its value: the child's, or its error raised again here; if the
    child is lost without a word (killed), or no child can be forked, ``fn(*args)`` is
    computed in this process when the value is asked for. The child inherits this process's
    memory, so what was computed before the fork is not computed again."""
    import multiprocessing as mp

    try:
        ctx = mp.get_context("fork")
        receive, send = ctx.Pipe(duplex=False)
        child = ctx.Process(target=_answer, args=(send, os.getpid(), fn, args))
        child.start()
    except (ValueError, OSError, AssertionError):  # no fork here, or a daemon's child
        return lambda: fn(*args)
    send.close()

    def wait():
        try:
            kind, value = receive.recv()
        except (EOFError, OSError):
            kind, value = "lost", None
        finally:
            receive.close()
            child.join()
        if kind == "error":
            raise value
        return value if kind == "value" else fn(*args)
    return wait


def _answer(send, parent_pid: int, fn, args) -> None:
    die_with_parent(parent_pid)
    try:
        send.send(("value", fn(*args)))
    except BaseException as error:      # noqa: BLE001 - handed to the parent as it is
        send.send(("error", error))
    finally:
        send.close()

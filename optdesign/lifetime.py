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
Ctrl-C. Neither is lost: both are held while a child is forked (:func:`signals_held`), and
one whose exception Python or CasADi drops is raised again (:func:`raise_if_terminated`,
:func:`interrupts_kept`).
"""
from __future__ import annotations

import os
import signal
import sys
import threading
from contextlib import contextmanager
from functools import partial

#: seconds between two checks of the watchdog
WATCH_INTERVAL_S = 0.5
#: the signals held while a child is forked (:func:`signals_held`)
HELD = (signal.SIGINT, signal.SIGTERM)
_PR_SET_PDEATHSIG = 1


def die_with_parent(parent_pid: int | None = None) -> None:
    """Make this (child) process end when ``parent_pid`` (default: its parent now) dies,
    and at once on SIGTERM; it ignores SIGINT (its parent ends it).

    Usable as a ``ProcessPoolExecutor`` initializer: ``initializer=die_with_parent,
    initargs=(os.getpid(),)``.
    """
    parent_pid = parent_pid or os.getppid()
    try:        # not the parent's handler of :func:`exit_on_sigterm`: a worker just ends
        # (even where the caller ignores SIGTERM: it is how its command ends it)
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


@contextmanager
def signals_held():
    """Hold Ctrl-C and SIGTERM while the block forks a child; deliver them as it ends.

    A signal that lands while CPython runs its at-fork handlers (logging's lock release, in
    the parent, right after ``fork``) raises its exception inside that handler, where Python
    prints "Exception ignored" and drops it: the command would go on as if never
    interrupted. Inside the block their Python handlers only record them (whichever thread
    the kernel hands a signal to, its Python handler runs in the main thread); as the block
    ends, the handler of the first one recorded is called, where its exception unwinds as
    anywhere else. A child forked inside records them too until it sets its own
    (:func:`die_with_parent`). A no-op outside the main thread."""
    with _handlers_wrapped(HELD, through=False):
        yield


@contextmanager
def _handlers_wrapped(signums, through: bool):
    """Inside, each Python handler of ``signums`` is replaced by one that records the call
    and (``through``) passes it on; as the block ends, the handlers are put back and a
    recorded signal is handed to its handler again (with ``through``, only when the block
    ended without an exception: the handler's own, raised through, is on its way)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    handlers = {s: h for s in signums if callable(h := signal.getsignal(s))}
    came: list[int] = []

    def record(signum, frame):
        came.append(signum)
        if through:
            handlers[signum](signum, frame)

    for signum in handlers:
        signal.signal(signum, record)
    try:
        yield
    except BaseException:
        _put_back(handlers)
        if came and not through:
            handlers[came[0]](came[0], None)
        raise
    _put_back(handlers)
    if came:
        handlers[came[0]](came[0], None)


def _put_back(handlers: dict) -> None:
    for signum, handler in handlers.items():
        signal.signal(signum, handler)


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


_received: list[int] = []        # the signals received inside exit_on_sigterm, in order


def raise_if_terminated() -> None:
    """Raise the first signal received inside :func:`exit_on_sigterm` again:
    :class:`Terminated` for a SIGTERM, ``KeyboardInterrupt`` for a Ctrl-C. Its handler's
    exception can be lost: Python drops one that lands in a finaliser (``__del__``, a GC
    callback) or an at-fork handler, and CasADi's IPOPT swallows a Ctrl-C. Long loops call
    this, and nothing is published after either signal."""
    _raise_first(_received)


def _raise_first(signums: list[int]) -> None:
    if signums:
        if signums[0] == signal.SIGINT:
            raise KeyboardInterrupt
        raise Terminated(128 + signums[0])


@contextmanager
def exit_on_sigterm():
    """While inside, a SIGTERM raises :class:`Terminated` in the main thread and a Ctrl-C
    the exception of the SIGINT handler in force (``KeyboardInterrupt``), each recorded;
    leaving the block normally after one raises it again, as :func:`raise_if_terminated`
    does. The exception of a recorded signal that Python drops is not printed: it comes
    back. A signal the caller ignores (SIG_IGN) stays ignored. A no-op when called from
    another thread, where Python cannot install signal handlers."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, frame):
        signal.signal(signal.SIGTERM, signal.SIG_DFL)     # a second SIGTERM ends at once
        _received.append(signum)
        print("optdesign: terminated", file=sys.stderr)
        raise Terminated(128 + signum)

    ctrl_c = signal.getsignal(signal.SIGINT)

    def recorded(signum, frame):
        _received.append(signum)
        ctrl_c(signum, frame)

    _received.clear()
    previous = signal.getsignal(signal.SIGTERM)
    if previous != signal.SIG_IGN:          # one the caller ignores stays ignored
        signal.signal(signal.SIGTERM, handler)
    if callable(ctrl_c):
        signal.signal(signal.SIGINT, recorded)
    unraisable = sys.unraisablehook
    sys.unraisablehook = partial(_unless_received, unraisable)
    try:
        yield
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
        if callable(ctrl_c):
            signal.signal(signal.SIGINT, ctrl_c)
        sys.unraisablehook = unraisable
        received = _received[:]
        _received.clear()                   # nothing left for a later block of the process
    _raise_first(received)


def _unless_received(hook, unraisable) -> None:
    """``hook``, but silent on the dropped exception of a signal that was recorded."""
    if not (_received and unraisable.exc_type is not None
            and issubclass(unraisable.exc_type, (KeyboardInterrupt, Terminated))):
        hook(unraisable)


@contextmanager
def interrupts_kept():
    """Around a call into CasADi's IPOPT, which swallows a Ctrl-C: one that lands inside is
    raised again as the block ends.

    CasADi checks for Ctrl-C during IPOPT and, finding one, ends the run as failed
    ("NonIpopt_Exception_Thrown"), the KeyboardInterrupt consumed: the caller would go on
    with one failed run. Inside the block, the SIGINT handler in force (a Python one: the
    interpreter's, a notebook kernel's, :func:`exit_on_sigterm`'s) still runs, so IPOPT
    stops at once, and a call is recorded; as the block ends, the handler is called again
    where its exception can propagate. Nothing changes where SIGINT is ignored (a worker)
    or outside the main thread. CasADi's warning that it caught the Ctrl-C is not printed
    (:class:`_WithoutInterruptWarning`): the one line the command prints says so."""
    if threading.current_thread() is not threading.main_thread():
        yield                           # no Ctrl-C is handled here: nothing to keep
        return
    quiet = _WithoutInterruptWarning(sys.stderr)
    sys.stderr = quiet
    try:
        with _handlers_wrapped((signal.SIGINT,), through=True):
            yield
    finally:
        if sys.stderr is quiet:
            sys.stderr = quiet.stream
        quiet.close_line()


class _WithoutInterruptWarning:
    """``stream`` (standard error) less the lines of CasADi's warning that IPOPT was
    interrupted by a Ctrl-C. CasADi writes a line in many pieces, so a line that begins as
    CasADi's do is passed on whole (the last, unfinished one by :meth:`close_line`); any
    other text at once."""

    MARK = 'WARNING("KeyboardInterruptException")'

    def __init__(self, stream):
        self.stream, self.line = stream, ""

    def write(self, text: str) -> int:
        if not self.line and not text.startswith("CasADi"):
            return self.stream.write(text)
        *whole, self.line = (self.line + text).split("\n")
        for line in whole:
            if self.MARK not in line:
                self.stream.write(line + "\n")
        return len(text)

    def close_line(self) -> None:
        if self.line and self.MARK not in self.line:
            self.stream.write(self.line)
        self.line = ""

    def __getattr__(self, name):
        return getattr(self.stream, name)


def beside(fn, *args) -> "Beside":
    """Start ``fn(*args)`` in a forked child (that dies with this process) and return a
    :class:`Beside`, which waits for its value when called: the child's, or its error raised
    again here; if the child is lost without a word (killed), or no child can be forked,
    ``fn(*args)`` is computed in this process when the value is asked for. The child inherits
    this process's memory, so what was computed before the fork is not computed again."""
    import multiprocessing as mp

    try:
        ctx = mp.get_context("fork")
        receive, send = ctx.Pipe(duplex=False)
        child = ctx.Process(target=_answer, args=(send, receive, os.getpid(), fn, args))
        with signals_held():
            child.start()
    except (ValueError, OSError, AssertionError):  # no fork here, or a daemon's child
        return Beside(fn, args, None, None)
    send.close()
    return Beside(fn, args, child, receive)


class Beside:
    """A value computed in a child process (:func:`beside`): called, it waits for it
    (:meth:`ready` tells whether it would); :meth:`cancel` ends the child where the value is
    no longer wanted (the caller unwinds from an error or a Ctrl-C: a child left alone would
    compute on, then block on its pipe)."""

    def __init__(self, fn, args, child, receive):
        self.fn, self.args, self.child, self.receive = fn, args, child, receive

    def __call__(self):
        if self.child is None:
            return self.fn(*self.args)
        kind, value = received(self.receive, self.cancel)
        self._close(wait=False)
        if kind == "error":
            raise value
        return value if kind == "value" else self.fn(*self.args)

    def ready(self) -> bool:
        """Whether the value is in: asked for now, it would not wait for the child (its
        value or error has come, or it has ended; or there is no child, and the value would
        be computed here)."""
        return self.child is None or arrived(self.receive)

    def cancel(self) -> None:
        """End the child, if it still runs, and forget its value (asked for after this,
        it raises)."""
        if self.child is not None:
            self.child.kill()
            self._close()
        self.fn = cancelled

    def _close(self, wait: bool = True) -> None:
        """Close the pipe and let the child go; with ``wait``, once it has ended. Without,
        a child that has sent its value is not waited for as it exits (the end of a process
        that shares much of this one's memory takes milliseconds): multiprocessing reaps it
        as the next child starts, or as this process exits."""
        self.receive.close()
        self.child.join(None if wait else 0)
        self.child = None


def received(receive, cancel) -> tuple[str, object]:
    """The answer a child sends on the pipe end ``receive`` (("value", v) or ("error", e)),
    or ("lost", None) where the child ended without one; a Ctrl-C while waiting calls
    ``cancel`` (which ends the child) and is raised again (a kept child's value waits the
    same way: :class:`optdesign.kept_children.Kept`)."""
    try:
        return receive.recv()
    except (EOFError, OSError):
        return "lost", None
    except BaseException:
        cancel()
        raise


def arrived(receive) -> bool:
    """Whether :func:`received` would not wait: an answer has come, or the child ended."""
    try:
        return receive.poll(0)
    except (EOFError, OSError):
        return True


def cancelled(*_):
    """A cancelled value's function: asked for, it raises."""
    raise RuntimeError("a value computed beside was asked for after its child ended")


def _answer(send, receive, parent_pid: int, fn, args) -> None:
    receive.close()         # the parent's end: a parent that stops reading breaks the pipe
    die_with_parent(parent_pid)
    try:
        send.send(("value", fn(*args)))
    except BaseException as error:      # noqa: BLE001 - handed to the parent as it is
        send.send(("error", error))
    finally:
        send.close()

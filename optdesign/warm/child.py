"""The child the warm server forks for one command: it becomes the client's process, then runs
the command as the program does.

From the server it keeps only its imported modules. From the client it takes everything a
command can read: its standard input, output and error (the descriptors themselves, so a
terminal stays a terminal and a pipe a pipe), its working folder (as a descriptor: a folder
renamed meanwhile is still the one the user was in), its environment (and the locale it names),
umask and resource limits, its program name and arguments, and the encoding of its streams. It
leads a process group of its own, which the client sends Ctrl-C and the other signals to; it
resets every signal handler and descriptor of the server and takes on the client's signal
dispositions (a signal the caller ignored stays ignored) and blocked signals. A thread watches
the connection: if the client dies, the group gets SIGTERM (a ``solve`` in progress unwinds and
removes its unfinished set, :func:`optdesign.lifetime.exit_on_sigterm`).
"""
from __future__ import annotations

import io
import os
import signal
import socket
import sys
import threading
from typing import Callable, NamedTuple

from optdesign.warm import client, wire


class Program(NamedTuple):
    """The command line as the server runs it (given by :mod:`optdesign.cli`, which this
    package does not import)."""

    #: runs ``sys.argv`` as the program does and ends the process
    main: Callable[[], None]
    #: ends the process with an exit code, its output flushed
    exit_now: Callable[[int], None]
    #: builds the argument parser, importing every command's module
    parser: Callable[[], object]


def run(request: dict, fds: list[int], conn: socket.socket, inherited: list[int],
        program: Program) -> None:
    """Take on the client's process state and run its command with ``program``; never
    returns. It starts only on the client's ``go`` (a client that gave up waiting runs the
    command itself: this child then ends, having done nothing). If the state cannot be taken
    on, the client is told to run the command itself."""
    try:
        _adopt(request, fds, inherited)      # nothing run yet: the client's handlers in force
        if not _go(conn):
            os._exit(0)
        _watch(conn)
    except KeyboardInterrupt:            # Ctrl-C before the command started, as run alone
        print("optdesign: interrupted", file=sys.stderr, flush=True)
        os._exit(128 + signal.SIGINT)
    except BaseException:               # noqa: BLE001 - whatever it is, the client runs it
        try:
            conn.sendall(b"cold\n")
        finally:
            os._exit(0)
    client.mark_served()
    sys.argv = [request.get("program") or "optdesign", *request["argv"]]
    try:
        program.main()                   # ends the process itself, but for a SystemExit
    except SystemExit as exc:            # --version, --help, a usage error: as Python ends
        program.exit_now(_exit_code(exc.code))
    except KeyboardInterrupt:            # Ctrl-C before the command started
        program.exit_now(128 + signal.SIGINT)
    except BaseException:               # noqa: BLE001 - printed as Python prints it
        import traceback
        traceback.print_exc()
        program.exit_now(1)


def _go(conn: socket.socket) -> bool:
    """Wait for the client's ``go``; False when it closed instead. No deadline: the client
    decides, and its end closes when it dies."""
    conn.settimeout(None)
    word = b""
    try:
        while len(word) < len(wire.GO):
            chunk = conn.recv(len(wire.GO) - len(word))
            if not chunk:
                return False
            word += chunk
    except OSError:
        return False
    return word == wire.GO


def _exit_code(code) -> int:
    """The exit code of ``sys.exit(code)``: None is 0, a number itself, anything else is
    printed on stderr and is 1."""
    if code is None:
        return 0
    if isinstance(code, int):
        return code & 0xFF
    print(code, file=sys.stderr)
    return 1


def _adopt(request: dict, fds: list[int], inherited: list[int]) -> None:
    if len(fds) != wire.RUN_FDS:
        raise ValueError("a run request carries four descriptors")
    for fd in inherited:
        _close(fd)
    signal.set_wakeup_fd(-1)
    _signals(request.get("signals") or {})
    try:
        os.setpgid(0, 0)                 # the server has made it so already, or will
    except OSError:
        pass
    for target, fd in enumerate(fds[:3]):
        os.dup2(fd, target)
    os.fchdir(fds[3])
    for fd in fds:
        if fd > 2:
            _close(fd)
    os.umask(int(request["umask"]))
    _limit(request.get("limits", {}))
    os.environ.clear()
    os.environ.update({str(k): str(v) for k, v in request["environment"].items()})
    if "tempfile" in sys.modules:
        sys.modules["tempfile"].tempdir = None       # found again from TMPDIR
    _locale()
    _streams(request.get("streams") or [None, None, None])
    from optdesign.outputs import phases
    phases.restart(float(request["started"]))


def _signals(state: dict) -> None:
    """The server's handlers undone, and the client's dispositions taken on: a signal its
    caller ignores (``nohup``'s SIGHUP, a background job's SIGINT) is ignored here and in
    every process the command forks, as it would be in the program run alone; its blocked
    signals stay blocked."""
    signal.signal(signal.SIGINT, signal.default_int_handler)
    for signum in (signal.SIGTERM, signal.SIGHUP, signal.SIGQUIT, signal.SIGCHLD):
        signal.signal(signum, signal.SIG_DFL)
    for signum in state.get("ignored", []):
        try:
            signal.signal(int(signum), signal.SIG_IGN)
        except (OSError, ValueError, TypeError):    # SIGKILL, SIGSTOP: never ignored
            pass
    blocked = set()
    for signum in state.get("blocked", []):
        if isinstance(signum, int) and 0 < signum < signal.NSIG:
            blocked.add(signum)
    signal.pthread_sigmask(signal.SIG_SETMASK, blocked)


def _locale() -> None:
    """The client's character type locale, set from its environment as Python sets it at
    start-up (the encodings that depends on are the server's own: the fingerprint holds
    them, :func:`optdesign.warm.place.text_encodings`)."""
    import locale

    try:
        locale.setlocale(locale.LC_CTYPE, "")
    except locale.Error:                # an unknown locale: C, as Python falls back
        locale.setlocale(locale.LC_CTYPE, "C")


def _limit(limits: dict) -> None:
    """The client's resource limits (a limit above what the server may grant stays the
    server's)."""
    import resource

    for name, (soft, hard) in limits.items():
        which = getattr(resource, str(name), None)
        if not str(name).startswith("RLIMIT_") or which is None:
            continue
        try:
            resource.setrlimit(which, (int(soft), int(hard)))
        except (OSError, ValueError):
            pass


def _streams(encodings: list) -> None:
    """sys.stdin, stdout and stderr over descriptors 0, 1 and 2, buffered as Python
    buffers them: stdout by lines on a terminal, stderr by lines always."""
    def text(fd, mode, encoding, line_buffering):
        encoding, errors = encoding if encoding else (None, None)
        raw = io.open(fd, mode + "b", closefd=False)
        return io.TextIOWrapper(raw, encoding=encoding, errors=errors,
                                line_buffering=line_buffering)

    sys.stdin = sys.__stdin__ = text(0, "r", encodings[0], False)
    sys.stdout = sys.__stdout__ = text(1, "w", encodings[1], os.isatty(1))
    sys.stderr = sys.__stderr__ = text(2, "w", encodings[2], True)


def _watch(conn: socket.socket) -> None:
    """End the command's process group by SIGTERM when the client's end closes."""
    conn.settimeout(None)

    def watch():
        try:
            while conn.recv(4096):
                pass
        except OSError:
            pass
        try:
            os.killpg(0, signal.SIGTERM)
        except OSError:
            pass
    threading.Thread(target=watch, name="client-watch", daemon=True).start()


def _close(fd: int) -> None:
    try:
        os.close(fd)
    except OSError:
        pass

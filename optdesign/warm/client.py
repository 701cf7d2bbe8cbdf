"""The program's side of the warm server: hand the command over, or run it here and start one.

:func:`delegate` gives the command to this installation's server when one is listening with the
same fingerprint (:mod:`optdesign.warm.place`) and returns its exit code; it returns None when
the command is to run in this process: no server, another fingerprint, the server off
(``OPTDESIGN_SERVER=off``), a server that does not answer within :data:`HANDSHAKE_TIMEOUT_S`
(stopped, stuck), or anything unusual (a closed standard stream, a working folder that cannot
be opened). Signals the caller ignores stay ignored: they are neither passed on nor taken by
the child (:mod:`optdesign.warm.child`). While the child runs, Ctrl-C, SIGTERM, SIGHUP and
SIGQUIT received here are sent to the child's process group, as a terminal sends them to a
program's, and Ctrl-Z stops the child with this process (``fg`` and ``bg`` go on with both); if
this process dies, the child is ended by SIGTERM (:mod:`optdesign.warm.child`).

After a command that found no server, :func:`start_server_if_missing` starts one in the
background for the next command. Nothing here imports more than the standard library.
"""
from __future__ import annotations

import os
import signal
import socket
import sys
import time

from optdesign.warm import place, wire

#: seconds the server has to answer a command with its child's pid; a server stopped
#: (SIGSTOP) or stuck meanwhile is given up and the command runs in this process
HANDSHAKE_TIMEOUT_S = 3.0
#: signals passed on to the command's process group
FORWARDED = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP, signal.SIGQUIT)
#: commands never handed over: the server's own, and the explorer (a server of its own that
#: runs until Ctrl-C: its event loop and threads belong in a process of their own)
_LOCAL = {"server", "explore"}
#: signals the interpreter ignores at its start, whatever its caller set
_PYTHON_IGNORES = {getattr(signal, name) for name in ("SIGPIPE", "SIGXFSZ")
                   if hasattr(signal, name)}
_missing: list[bool] = []        # set by delegate when no server answered
_served: list[bool] = []         # set in the server's child: the command runs here
_environment: list[dict] = []    # the environment as the program found it


def delegate(argv: list[str], started: float) -> int | None:
    """The exit code of ``argv`` run by the warm server, or None to run it here (see the
    module's text). ``started``: the program's start on the wall clock."""
    env = dict(os.environ)
    _environment[:] = [env]
    if _served or not place.enabled(env) or (argv and argv[0] in _LOCAL):
        return None
    path = place.socket_path(env)
    if path is None:
        return None
    if not place.private(path.parent):
        if not os.path.lexists(path.parent):     # made private when a server starts
            _missing.append(True)
        return None
    deadline = time.monotonic() + HANDSHAKE_TIMEOUT_S
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as sock:
        sock.settimeout(HANDSHAKE_TIMEOUT_S)      # a stopped server's backlog may be full
        try:
            sock.connect(os.fspath(path))
        except TimeoutError:
            return None
        except OSError:
            _missing.append(True)
            return None
        lines = wire.Lines(sock)
        # the standard streams go only to a server that answers: descriptors sent to one
        # that is stopped would stay open in its socket, and a pipe read by the caller
        # (``optdesign analyze P | tail``) would never end
        try:
            greeting = lines.next()
        except TimeoutError:
            return None
        except OSError:
            greeting = None
        if greeting != ("ready", ""):           # wire.READY
            _missing.append(True)
            return None
        return _hand_over(sock, lines, argv, env, started, deadline)


def _hand_over(sock: socket.socket, lines: wire.Lines, argv: list[str], env: dict,
               started: float, deadline: float) -> int | None:
    try:
        fds = [0, 1, 2]
        for fd in fds:
            os.fstat(fd)                 # a closed standard stream: run here, as it is
        cwd = os.open(".", os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC)
    except OSError:
        return None
    try:
        wire.send_request(sock, _run_request(argv, env, started), fds + [cwd])
    except OSError:
        return None
    finally:
        os.close(cwd)
    return _follow(sock, lines, deadline)


def _run_request(argv: list[str], env: dict, started: float) -> dict:
    import resource

    limits = {}
    for name in dir(resource):
        if name.startswith("RLIMIT_"):
            try:
                limits[name] = list(resource.getrlimit(getattr(resource, name)))
            except (OSError, ValueError):
                pass
    umask = os.umask(0)
    os.umask(umask)
    return {"kind": "run", "fingerprint": place.fingerprint(env),
            "program": sys.argv[0] if sys.argv else "optdesign", "argv": list(argv),
            "environment": env, "umask": umask, "limits": limits, "started": started,
            "streams": [_encoding(sys.stdin), _encoding(sys.stdout), _encoding(sys.stderr)],
            "signals": {"ignored": ignored_signals(),
                        "blocked": sorted(int(s) for s in
                                          signal.pthread_sigmask(signal.SIG_BLOCK, []))}}


def ignored_signals() -> list[int]:
    """The signals this process ignores as its caller left them (``nohup`` ignores SIGHUP, a
    shell's background job SIGINT and SIGQUIT): the command ignores them too, wherever it
    runs. SIGPIPE and SIGXFSZ are left out: every Python process ignores them itself."""
    ignored = []
    for signum in signal.valid_signals():
        if signum in _PYTHON_IGNORES:
            continue
        try:
            if signal.getsignal(signum) == signal.SIG_IGN:
                ignored.append(int(signum))
        except (ValueError, OSError):
            pass
    return ignored


def _encoding(stream) -> list[str] | None:
    return [stream.encoding, stream.errors] if stream is not None else None


def _follow(sock: socket.socket, lines: wire.Lines, deadline: float) -> int | None:
    """Wait for the child's exit code, passing signals on to its process group; None when
    no child started the command: the server closed first (it was stopping) or said
    nothing until ``deadline`` (it is stopped or stuck), and the command is to run here."""
    group: list[int] = []
    pending: list[int] = []

    def forward(signum, frame):
        if not group:
            pending.append(signum)
            return
        try:
            os.killpg(group[0], signum)
        except OSError:
            pass

    def suspend(signum, frame):         # Ctrl-Z: the command stops with this process
        forward(signal.SIGSTOP, frame)
        signal.signal(signal.SIGTSTP, signal.SIG_DFL)
        os.kill(os.getpid(), signal.SIGTSTP)         # stopped here until `fg` or `bg`
        signal.signal(signal.SIGTSTP, suspend)
        forward(signal.SIGCONT, frame)

    handlers = {s: forward for s in FORWARDED} | {signal.SIGTSTP: suspend}
    # a signal the caller ignores is ignored by the child too: nothing to pass on
    previous = {s: signal.signal(s, handler) for s, handler in handlers.items()
                if signal.getsignal(s) != signal.SIG_IGN}
    started = False
    try:
        while True:
            if not group:
                sock.settimeout(max(deadline - time.monotonic(), 0.001))
            try:
                line = lines.next()
            except TimeoutError:             # a silent server: the command runs here
                return None
            word, rest = line if line is not None else ("", "")
            if word == "cold" or (line is None and not group):
                _missing.append(True)
                return None
            if word == "pid" and not group and rest.isdigit():
                try:
                    sock.sendall(wire.GO)
                except OSError:              # the server is gone: the child never starts
                    return None
                sock.settimeout(None)       # a command takes as long as it takes
                group.append(int(rest))
                started = True
                for signum in pending:
                    forward(signum, None)
            elif word == "exit" and rest.lstrip("-").isdigit():
                return int(rest)
            elif line is None:
                print("optdesign: the warm server ended before the command did "
                      "(killed?); run it again, or with OPTDESIGN_SERVER=off",
                      file=sys.stderr, flush=True)
                return 1
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
        if not started:                 # the command runs here: what came is its own
            for signum in pending:
                signal.raise_signal(signum)


def program_environment() -> dict:
    """The environment as the program found it, before the command line set its defaults
    (``MPLBACKEND``)."""
    return dict(_environment[0]) if _environment else dict(os.environ)


def mark_served() -> None:
    """This process is the server's child running a command: it hands nothing over."""
    _served.append(True)


def start_server_if_missing() -> None:
    """Start this installation's server in the background if the last :func:`delegate`
    found none (it imports its libraries, then listens; a server already starting keeps
    its lock and the new one ends at once)."""
    if not _missing or not _environment or _served:
        return
    start_server(_environment[0])


def start_server(env: dict) -> int | None:
    """Start a server with the environment ``env``; its pid, or None where none can start."""
    path = place.socket_path(env)
    if path is None or not place.private(path.parent, create=True):
        return None
    import json
    import subprocess

    boot = ("import sys, json; sys.path[:] = json.loads(sys.argv[1]); "
            "from optdesign.cli import serve_warm; serve_warm()")
    search = [entry or os.getcwd() for entry in sys.path]   # the server runs in /
    try:
        child = subprocess.Popen([sys.executable, "-c", boot, json.dumps(search)],
                                 env=env, cwd="/", start_new_session=True,
                                 stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                 stderr=subprocess.DEVNULL)
    except OSError:
        return None
    return child.pid


def ask(kind: str, env=os.environ) -> dict | None:
    """The server's answer to ``status`` (its state) or ``stop``; None when none listens."""
    path = place.socket_path(env)
    if path is None or not place.private(path.parent):
        return None
    try:
        with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as sock:
            sock.settimeout(10)
            sock.connect(os.fspath(path))
            lines = wire.Lines(sock)
            if lines.next() != ("ready", ""):       # wire.READY
                return None
            wire.send_request(sock, {"kind": kind})
            line = lines.next()
    except OSError:
        return None
    if line is None:
        return None
    if kind == "status":
        import json
        try:
            return json.loads(" ".join(line))
        except ValueError:
            return None
    return {"stopped": line[0] == "stopped"}

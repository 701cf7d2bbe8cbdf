"""The warm server: import once, then fork a child per command.

Started in the background by a command that found none (:func:`optdesign.warm.client.
start_server`), in a session of its own, in ``/``, its standard streams on ``/dev/null``. It

1. takes the lock beside its socket (a second server of the same installation ends here);
2. imports the command line, every module of the package and the libraries the commands
   import as they run, and draws matplotlib's first figure (the fonts);
3. listens on its socket (mode 0600, in the private folder of :mod:`optdesign.warm.place`),
   answering only processes of its own user;
4. reads each request as its bytes arrive, every connection with a deadline of its own
   (:data:`REQUEST_TIMEOUT_S`), so a slow, stopped or idle client delays no other; forks one
   child per ``run`` request (:mod:`optdesign.warm.child`), tells the client the child's
   pid, and when the child ends, its exit code;
5. ends after ``OPTDESIGN_SERVER_IDLE`` seconds (15 minutes) without a command, on SIGTERM,
   on ``optdesign server stop``, or at a request whose fingerprint is not its own (its files
   or environment changed: it is stale). It first stops listening and gives up its lock, so
   that a new server can start at once; the commands it is running finish and get their
   exit codes.

It starts no thread: a fork copies no thread of its own in the middle of holding a lock. (The
BLAS libraries of NumPy and SciPy keep idle worker threads, in every command as here; they
ready themselves for a fork, ``pthread_atfork``, as when a command forks its figures' process.)
"""
from __future__ import annotations

import os
import selectors
import signal
import socket
import struct
import time

from optdesign.warm import child, place, wire

#: seconds a client has, from its connection, to send its whole request
REQUEST_TIMEOUT_S = 3.0
#: connections whose request is still arriving; beyond, the oldest is dropped
MAX_PENDING = 64
#: seconds an answer (a line) may take to leave: a client that does not read is dropped
ANSWER_TIMEOUT_S = 2.0
#: libraries the commands import inside their functions (the package's modules are walked)
LIBRARIES = ("numpy", "casadi", "yaml", "scipy.optimize", "scipy.stats", "scipy.integrate",
             "scipy.special", "pandas", "tqdm", "matplotlib.pyplot", "PIL.Image", "ezdxf",
             "multiprocessing.popen_fork", "multiprocessing.synchronize",
             "encodings.utf_8_sig")
_UCRED = struct.Struct("3i")
#: the package's parts the server does not import: itself, and the program's entry
_NOT_PRELOADED = {"warm", "__main__"}


def main(program: child.Program) -> None:
    """Run the server (the background process's whole life) for the command line
    ``program``; returns when it ends."""
    env = dict(os.environ)
    os.environ.pop("OPTDESIGN_PHASES", None)        # the server's exit writes no phase line
    path = place.socket_path(env)
    if path is None or not place.private(path.parent, create=True):
        return
    lock = _lock(path.with_suffix(".lock"))
    if lock is None:
        return
    try:
        idle = place.idle_seconds(env)
    except place.SettingError:
        idle = place.IDLE_DEFAULT_S
    mine = place.fingerprint(env)
    os.environ.setdefault("MPLBACKEND", "Agg")       # as the program sets it
    preload(program)
    if place.fingerprint(env) != mine:               # a file changed while importing
        return
    listener = _listen(path)
    Server(listener, path, lock, mine, idle, program).serve()


def preload(program: child.Program) -> None:
    """Import what the commands import, and draw a first figure."""
    import importlib
    import pkgutil

    import optdesign

    program.parser()
    for info in pkgutil.walk_packages(optdesign.__path__, "optdesign.",
                                      onerror=lambda name: None):
        if info.name.split(".")[1] not in _NOT_PRELOADED:
            _quietly(importlib.import_module, info.name)
    for name in LIBRARIES:
        _quietly(importlib.import_module, name)
    from optdesign.figures.design import warm_up
    _quietly(warm_up)


def _quietly(fn, *args) -> None:
    try:
        fn(*args)
    except Exception:           # noqa: BLE001 - the command that needs it will say why
        pass


def _lock(path) -> int | None:
    """The lock's descriptor, held for the server's life; None if another server has it."""
    import fcntl

    try:
        fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC, 0o600)
    except OSError:
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        os.close(fd)
        return None
    return fd


def _listen(path) -> socket.socket:
    """The listening socket at ``path`` (a socket left there by a killed server is removed:
    the lock says no server owns it)."""
    try:
        os.unlink(path)
    except FileNotFoundError:
        pass
    listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    listener.bind(os.fspath(path))
    os.chmod(path, 0o600)
    listener.listen(64)
    listener.setblocking(False)
    return listener


class Server:
    """The listening loop (see the module's text)."""

    def __init__(self, listener: socket.socket, path, lock: int, fingerprint: str,
                 idle_s: float, program: child.Program):
        self.listener, self.path, self.lock = listener, path, lock
        self.fingerprint, self.idle_s = fingerprint, idle_s
        self.inode = os.lstat(path).st_ino
        self.program = program
        self.children: dict[int, socket.socket] = {}
        #: connections whose request is arriving: their reader and deadline, oldest first
        self.pending: dict[socket.socket, tuple[wire.RequestReader, float]] = {}
        self.started = time.time()
        self.last = time.monotonic()
        self.selector = selectors.DefaultSelector()

    def serve(self) -> None:
        wake_r, wake_w = os.pipe()
        for fd in (wake_r, wake_w):
            os.set_blocking(fd, False)
        self.wake = (wake_r, wake_w)
        signal.set_wakeup_fd(wake_w)
        signal.signal(signal.SIGCHLD, lambda *_: None)
        signal.signal(signal.SIGTERM, lambda *_: self.stop_listening())
        for signum in (signal.SIGINT, signal.SIGHUP):
            signal.signal(signum, signal.SIG_IGN)
        self.selector.register(self.listener, selectors.EVENT_READ)
        self.selector.register(wake_r, selectors.EVENT_READ)
        try:
            while self.listener is not None or self.children:
                now = time.monotonic()
                idle_left = self.last + self.idle_s - now
                if not self.children and not self.pending and idle_left <= 0:
                    break
                waits = [d - now for _, d in self.pending.values()]
                if not self.children:
                    waits.append(idle_left)
                timeout = max(0.0, min(waits)) if waits else None
                for key, _ in self.selector.select(timeout):
                    if key.fd == wake_r:
                        _drain(wake_r)
                    elif key.fileobj is self.listener:
                        self._accept()
                    elif key.fileobj in self.pending:
                        self._read(key.fileobj)
                self._expire()
                self._reap()
        finally:
            self.stop_listening()
            for conn in list(self.pending):
                self._drop(conn)

    def stop_listening(self) -> None:
        """Take no more commands, give up the socket and the lock (a new server may start);
        the children running go on."""
        if self.listener is None:
            return
        self.selector.unregister(self.listener)
        try:
            if os.lstat(self.path).st_ino == self.inode:      # not a later server's
                os.unlink(self.path)
        except OSError:
            pass
        self.listener.close()
        self.listener = None
        os.close(self.lock)
        for conn in list(self.pending):      # their clients run their commands themselves
            self._drop(conn)

    # ------------------------------------------------------------------ one connection
    # A request is read as its bytes arrive, each connection with a deadline of its own:
    # a client that is slow, stopped or silent is dropped and never delays another.
    def _accept(self) -> None:
        while self.listener is not None:
            try:
                conn, _ = self.listener.accept()
            except (BlockingIOError, InterruptedError):
                return
            except OSError:                  # out of descriptors: the next select retries
                return
            try:
                _, uid, _ = _UCRED.unpack(conn.getsockopt(
                    socket.SOL_SOCKET, socket.SO_PEERCRED, _UCRED.size))
            except OSError:
                uid = -1
            if uid != os.getuid():
                conn.close()
                continue
            conn.setblocking(False)
            try:
                conn.send(wire.READY)
            except OSError:
                conn.close()
                continue
            if len(self.pending) >= MAX_PENDING:
                self._drop(next(iter(self.pending)))
            self.pending[conn] = (wire.RequestReader(conn),
                                  time.monotonic() + REQUEST_TIMEOUT_S)
            self.selector.register(conn, selectors.EVENT_READ)

    def _read(self, conn: socket.socket) -> None:
        reader, _ = self.pending[conn]
        try:
            request = reader.feed()
        except (OSError, ValueError):
            self._drop(conn)
            return
        if request is None:
            return
        del self.pending[conn]
        self.selector.unregister(conn)
        conn.setblocking(True)
        conn.settimeout(ANSWER_TIMEOUT_S)
        self._answer(request, reader.fds, conn)

    def _expire(self) -> None:
        now = time.monotonic()
        for conn in [c for c, (_, deadline) in self.pending.items() if deadline <= now]:
            self._drop(conn)

    def _drop(self, conn: socket.socket) -> None:
        """Close a connection whose request never came whole (and what it carried)."""
        reader, _ = self.pending.pop(conn, (None, None))
        if reader is not None:
            reader.close()
        try:
            self.selector.unregister(conn)
        except (KeyError, ValueError):
            pass
        conn.close()

    def _answer(self, request: dict, fds: list[int], conn: socket.socket) -> None:
        kind = request.get("kind")
        if kind == "run" and request.get("fingerprint") == self.fingerprint and \
                self.listener is not None:
            self._fork(request, fds, conn)
            return
        for fd in fds:
            os.close(fd)
        try:
            if kind == "run":                  # another installation state: this one is stale
                conn.sendall(b"cold\n")
                self.stop_listening()
            elif kind == "status":
                conn.sendall(self._status() + b"\n")
            elif kind == "stop":
                self.stop_listening()
                conn.sendall(b"stopped\n")
        except OSError:
            pass
        conn.close()

    def _status(self) -> bytes:
        import json

        return json.dumps({"pid": os.getpid(), "started": self.started,
                           "commands_running": len(self.children),
                           "idle_s": self.idle_s,
                           "fingerprint": self.fingerprint}).encode()

    def _fork(self, request: dict, fds: list[int], conn: socket.socket) -> None:
        inherited = [*self.wake, self.lock, self.selector.fileno(),
                     *([self.listener.fileno()] if self.listener is not None else []),
                     *(c.fileno() for c in self.children.values()),
                     *(c.fileno() for c in self.pending),
                     *(fd for reader, _ in self.pending.values() for fd in reader.fds)]
        pid = os.fork()
        if pid == 0:                     # the child never returns into the loop
            try:
                child.run(request, fds, conn, inherited, self.program)
            finally:
                os._exit(1)
        for fd in fds:
            os.close(fd)
        try:
            os.setpgid(pid, pid)
        except OSError:
            pass
        self.children[pid] = conn
        self.last = time.monotonic()      # a status or a stop is no command: it counts not
        try:
            conn.sendall(f"pid {pid}\n".encode())
        except OSError:                  # the client is gone: the child's watcher ends it
            pass

    def _reap(self) -> None:
        while self.children:
            try:
                pid, status = os.waitpid(-1, os.WNOHANG)
            except ChildProcessError:
                return
            if pid == 0:
                return
            conn = self.children.pop(pid, None)
            if conn is None:
                continue
            code = os.waitstatus_to_exitcode(status)
            try:
                conn.sendall(f"exit {128 - code if code < 0 else code}\n".encode())
            except OSError:
                pass
            conn.close()
            self.last = time.monotonic()


def _drain(fd: int) -> None:
    try:
        while os.read(fd, 4096):
            pass
    except (BlockingIOError, InterruptedError):
        pass

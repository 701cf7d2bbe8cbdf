"""The few messages between the program and the warm server, over a Unix stream socket.

The server greets each connection it takes with ``ready``; only then does the client send its
request, a length (8 bytes, big-endian) and a JSON object; a ``run`` request's length
carries the client's standard input, output and error and its working folder as file
descriptors (``SCM_RIGHTS``). The server answers with lines: ``pid N`` (the child that will
run the command, leader of its own process group), ``exit CODE`` (its exit code, 128 + the
signal that killed it), ``cold`` (run the command yourself: the server cannot, e.g. another
installation's fingerprint; it then ends), and for ``status`` one JSON line. The child starts
the command only when the client answers ``pid N`` with ``go``: a client that gave up
waiting (a stopped server) closes instead and runs the command itself, and the child ends
without a trace, so a command never runs twice.
"""
from __future__ import annotations

import json
import os
import socket
import struct

_LENGTH = struct.Struct("!Q")
#: the largest request taken (an environment of a few hundred kB at most)
MAX_REQUEST_BYTES = 1 << 24
#: the file descriptors a ``run`` request carries: stdin, stdout, stderr, working folder
RUN_FDS = 4
#: the client's word that starts the command
GO = b"go\n"
#: the server's first line on a connection it took
READY = b"ready\n"


def send_request(sock: socket.socket, request: dict, fds: list[int] = ()) -> None:
    body = json.dumps(request).encode("utf-8", "surrogateescape")
    head = _LENGTH.pack(len(body))
    if fds:
        sent = socket.send_fds(sock, [head], list(fds))
        sock.sendall(head[sent:])
    else:
        sock.sendall(head)
    sock.sendall(body)


class RequestReader:
    """A request read from a non-blocking socket as its bytes arrive, so that a server
    reading many never waits on one (a client sending a byte at a time, or nothing)."""

    def __init__(self, sock: socket.socket):
        self.sock = sock
        self.data = bytearray()
        #: the descriptors received so far (the caller closes them if it gives up)
        self.fds: list[int] = []

    def feed(self) -> dict | None:
        """Read what has arrived: the request once it is whole, else None. ValueError for
        anything malformed or cut short (its descriptors are closed first)."""
        try:
            while True:
                want = self._wanted()
                if want == 0:
                    return self._parsed()
                try:
                    chunk, fds, _, _ = socket.recv_fds(self.sock, min(want, 1 << 20),
                                                       RUN_FDS + 1)
                except (BlockingIOError, InterruptedError):
                    return None
                self.fds += fds
                if len(self.fds) > RUN_FDS:
                    raise ValueError("too many descriptors")
                if not chunk:
                    raise ValueError("request cut short")
                self.data += chunk
        except BaseException:
            self.close()
            raise

    def _wanted(self) -> int:
        """How many more bytes the request has."""
        if len(self.data) < _LENGTH.size:
            return _LENGTH.size - len(self.data)
        (length,) = _LENGTH.unpack_from(self.data)
        if length > MAX_REQUEST_BYTES:
            raise ValueError("request too long")
        return _LENGTH.size + length - len(self.data)

    def _parsed(self) -> dict:
        body = bytes(self.data[_LENGTH.size:])
        request = json.loads(body.decode("utf-8", "surrogateescape"))
        if not isinstance(request, dict):
            raise ValueError("request is not an object")
        return request

    def close(self) -> None:
        """Close the descriptors received (the request was not taken)."""
        for fd in self.fds:
            _close(fd)
        self.fds = []


def _close(fd: int) -> None:
    try:
        os.close(fd)
    except OSError:
        pass


class Lines:
    """The server's answer, a line at a time."""

    def __init__(self, sock: socket.socket):
        self._file = sock.makefile("rb")

    def next(self) -> tuple[str, str] | None:
        """(word, rest) of the next line; None when the server closed first."""
        line = self._file.readline(1 << 20)
        if not line.endswith(b"\n"):
            return None
        word, _, rest = line.decode("utf-8", "replace").strip().partition(" ")
        return word, rest

"""The few messages between the program and the warm server, over a Unix stream socket.

A request is a length (8 bytes, big-endian) and a JSON object; a ``run`` request's length
carries the client's standard input, output and error and its working folder as file
descriptors (``SCM_RIGHTS``). The server answers with lines: ``pid N`` (the child running the
command, leader of its own process group), ``exit CODE`` (its exit code, 128 + the signal
that killed it), ``cold`` (run the command yourself: the server cannot, e.g. another
installation's fingerprint; it then ends), and for ``status`` one JSON line.
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


def send_request(sock: socket.socket, request: dict, fds: list[int] = ()) -> None:
    body = json.dumps(request).encode("utf-8", "surrogateescape")
    head = _LENGTH.pack(len(body))
    if fds:
        sent = socket.send_fds(sock, [head], list(fds))
        sock.sendall(head[sent:])
    else:
        sock.sendall(head)
    sock.sendall(body)


def receive_request(sock: socket.socket) -> tuple[dict, list[int]]:
    """(the request, the descriptors it carried); ValueError for anything malformed (the
    descriptors received are closed first)."""
    head, fds, _, _ = socket.recv_fds(sock, _LENGTH.size, RUN_FDS + 1)
    try:
        head += _exactly(sock, _LENGTH.size - len(head))
        (length,) = _LENGTH.unpack(head)
        if length > MAX_REQUEST_BYTES:
            raise ValueError("request too long")
        request = json.loads(_exactly(sock, length).decode("utf-8", "surrogateescape"))
        if not isinstance(request, dict):
            raise ValueError("request is not an object")
        return request, fds
    except BaseException:
        for fd in fds:
            _close(fd)
        raise


def _exactly(sock: socket.socket, n: int) -> bytes:
    chunks = []
    while n > 0:
        chunk = sock.recv(min(n, 1 << 20))
        if not chunk:
            raise ValueError("request cut short")
        chunks.append(chunk)
        n -= len(chunk)
    return b"".join(chunks)


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

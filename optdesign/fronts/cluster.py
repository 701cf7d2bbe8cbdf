"""Reaching a Dask scheduler (``--scheduler ADDRESS``, ``pareto(scheduler=...)``) within one
deadline, and telling a scheduler from anything else that answers at the address.

A Dask scheduler speaks first: on every new connection each side writes its handshake, a
message of the TCP comm's framing (``distributed.comm.tcp``: the size of what follows as an
uint64, then the number of frames and each frame's length, then the frames). So before a ``distributed.Client`` is made, a plain socket
connects and reads that header within the deadline: silence (an HTTP server waits for a
request) or a header no Dask message has (garbage, another protocol) is "not a Dask scheduler
at ADDRESS", found in a few seconds, never a hang or a read of a length that exhausts memory.
"""
from __future__ import annotations

import socket
import struct
import time

from optdesign.errors import UsageError, shown

#: seconds to reach a scheduler, identify it and make the client (one deadline for all)
SCHEDULER_TIMEOUT_S = 3.0
#: a handshake is a few small frames
MAX_FRAMES = 64
MAX_HANDSHAKE_BYTES = 1 << 20


def connect(address, timeout: float = SCHEDULER_TIMEOUT_S):
    """A ``distributed.Client`` of ``address`` (or ``address`` itself when it is a client
    already), connected and checked within ``timeout`` seconds. Raises :class:`UsageError`
    (exit 2) for a malformed address, no answer, or something that is not a Dask scheduler."""
    if not isinstance(address, str):
        return address
    try:
        from distributed import Client
    except ImportError:
        raise UsageError("--scheduler needs dask distributed: pip install "
                         "'optdesign[cluster]'") from None
    deadline = time.monotonic() + timeout
    host_port = _tcp(address)
    if host_port is not None:
        _probe(address, *host_port, deadline, timeout)
    try:
        return Client(address, timeout=max(0.5, deadline - time.monotonic()))
    except (OSError, ValueError, TypeError) as exc:
        reason = "malformed address" if isinstance(exc, (ValueError, TypeError)) else \
            f"no scheduler answered within {timeout:g} s"
        raise UsageError(f"--scheduler {shown(address)}: {reason}") from None


def _tcp(address: str):
    """(host, port) of a plain TCP address (``tcp://host:port`` or ``host:port``); None for
    another scheme (tls, inproc, ucx: left to Dask)."""
    scheme, _, rest = address.rpartition("://")
    if scheme not in ("", "tcp"):
        return None
    host, _, port = rest.rpartition(":")
    host = host.strip("[]")
    if not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise UsageError(f"--scheduler {shown(address)}: malformed address (give "
                         f"tcp://HOST:PORT)")
    return host, int(port)


def _probe(address: str, host: str, port: int, deadline: float, timeout: float) -> None:
    """Connect and read the handshake's header before the deadline, or raise."""
    def remaining() -> float:
        left = deadline - time.monotonic()
        if left <= 0:
            raise socket.timeout
        return left

    try:
        with socket.create_connection((host, port), timeout=remaining()) as sock:
            size, frames = struct.unpack("<QQ", _read(sock, 16, remaining))
            if not 0 < frames <= MAX_FRAMES or not 8 * (frames + 1) <= size <= \
                    MAX_HANDSHAKE_BYTES:
                raise _NotDask
            lengths = struct.unpack(f"<{frames}Q", _read(sock, 8 * frames, remaining))
            if sum(lengths) + 8 * (frames + 1) > size:
                raise _NotDask
    except (_NotDask, socket.timeout, EOFError):
        raise UsageError(f"--scheduler {shown(address)}: not a Dask scheduler at "
                         f"{host}:{port} (it did not greet as one within the deadline)") \
            from None
    except OSError as exc:
        raise UsageError(f"--scheduler {shown(address)}: no scheduler answered within "
                         f"{timeout:g} s ({exc.strerror or type(exc).__name__})") from None


class _NotDask(Exception):
    """What answered does not frame its first message as Dask does."""


def _read(sock, n: int, remaining) -> bytes:
    data = b""
    while len(data) < n:
        sock.settimeout(remaining())
        chunk = sock.recv(n - len(data))
        if not chunk:
            raise EOFError
        data += chunk
    return data

"""How many bytes the C heap holds in use: what building a CasADi function keeps.

CasADi's graphs, derivatives and IPOPT's functions live in memory that C++ allocates through
``malloc``; glibc's ``mallinfo2`` tells the bytes allocated and not freed (small blocks and
blocks mapped on their own). The difference across a build is what the built object keeps,
whatever the allocator reuses of memory freed before it (a process's resident size does not
shrink when an object is let go, so its growth says nothing of the next build). Where the C
library has no ``mallinfo2`` (not glibc, or older than 2.33), nothing is measured.
"""
from __future__ import annotations

import ctypes


class _Mallinfo2(ctypes.Structure):
    _fields_ = [(name, ctypes.c_size_t) for name in (
        "arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks", "fsmblks", "uordblks",
        "fordblks", "keepcost")]


def _mallinfo2():
    try:
        function = ctypes.CDLL(None).mallinfo2
    except (OSError, AttributeError):
        return None
    function.restype = _Mallinfo2
    function.argtypes = []
    return function


_MALLINFO2 = _mallinfo2()


def in_use() -> int | None:
    """Bytes of the C heap in use now (allocated and not freed); None where unknown."""
    if _MALLINFO2 is None:
        return None
    info = _MALLINFO2()
    return int(info.uordblks + info.hblkhd)


def grown_since(before: int | None) -> int:
    """Bytes the heap holds beyond ``before`` (an :func:`in_use`), 0 where unknown or less."""
    now = in_use()
    return max(now - before, 0) if before is not None and now is not None else 0

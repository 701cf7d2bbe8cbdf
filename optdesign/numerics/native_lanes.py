"""The lanes' function compiled to C: the same values to the bit, up to 5 times faster.

The NumPy lanes (:mod:`optdesign.numerics.lanes`) apply each instruction of an SX function to
a whole array of inputs: one pass over memory per instruction, a few thousand passes per
call. The same function generated as C by CasADi and run lane by lane
(:data:`optdesign.numerics.c_library.LANES_DRIVER`) keeps every lane's intermediates in the
processor's registers and cache: on one thread the mechanisms' kinematics 1.9 to 5.0 times
faster, their speeds 0.9 to 3.5 times (``benchmarks/lanes_compiled.py``), and, as ``ctypes``
lets go of the interpreter while it runs, two threads share a call's lanes truly at once.

The values are the NumPy lanes' to the bit where the elementary functions agree: the C code
makes the same operations on the same operands (``-ffp-contract=off``: no fused
multiply-adds), and the arithmetic, the square root, the comparisons and ``fmax`` are
correctly rounded or exact in both. The transcendental functions (sin, cos, atan2, ...) are
the C library's in the compiled code and NumPy's in the lanes, which on some machines are
NumPy's own SIMD kernels (AVX-512): each one a function uses is compared with the C
library's (Python's ``math``) once per process on a fixed sample of arguments
(:func:`agrees`), and a function whose any one differs stays on the NumPy lanes. Functions
with ``pow`` or ``erf`` (NumPy's fast paths, scipy's erf) or ``hypot`` always do.

The library is built beside the work and kept in the user's cache like an NLP's
(:mod:`optdesign.numerics.c_library`: named by the function's digest, loaded only when it is
the user's own and intact, ``OPTDESIGN_COMPILE``); until it is there the NumPy lanes run.
"""
from __future__ import annotations

import ctypes
import hashlib
import math
import platform
from functools import lru_cache
from pathlib import Path

import casadi as ca
import numpy as np

from optdesign.numerics import c_library, user_cache

#: the library's layout (the driver's signature): part of the digest
FORMAT = 1
#: NumPy's functions in the lanes and the C library's (through Python's ``math``) they must
#: agree with, with the arguments they are compared on (:func:`agrees`)
CHECKED = {
    "sin": (math.sin, "wide"), "cos": (math.cos, "wide"), "tan": (math.tan, "wide"),
    "arcsin": (math.asin, "unit"), "arccos": (math.acos, "unit"), "arctan": (math.atan, "wide"),
    "sinh": (math.sinh, "narrow"), "cosh": (math.cosh, "narrow"),
    "tanh": (math.tanh, "narrow"), "arcsinh": (math.asinh, "wide"),
    "arccosh": (math.acosh, "positive"), "arctanh": (math.atanh, "unit"),
    "exp": (math.exp, "narrow"), "log": (math.log, "positive"),
    "expm1": (math.expm1, "narrow"), "log1p": (math.log1p, "positive"),
    "arctan2": (math.atan2, "pairs"),
}
GOLDEN, SQRT2 = (1 + 5 ** 0.5) / 2, 2 ** 0.5
#: NumPy functions a compiled loop never replaces (see the module's text)
NEVER = ("power", "erf", "hypot")
#: arguments per function compared (a millisecond of every process that loads a library; a
#: SIMD kernel of a few units in the last place differs from the C library on most of them)
SAMPLE = 1024


def recipe(fn: ca.Function, serialized: str) -> c_library.Recipe:
    """The recipe of ``fn``'s compiled lanes (``serialized``: ``fn.serialize()``)."""
    digest = hashlib.sha256()
    for part in (str(FORMAT), "lanes", ca.__version__, platform.machine(),
                 " ".join(c_library.FLAGS)):
        digest.update(part.encode() + b"\0")
    digest.update(serialized.encode())
    return c_library.Recipe(fn, serialized, "", digest.hexdigest(), kind="lanes")


def _arguments(kind: str) -> tuple[np.ndarray, ...]:
    """The fixed arguments a function is compared on: spread over its range by the additive
    sequences of the golden ratio and of √2 (the same in every process, and no random
    generator to load)."""
    k = np.arange(1, SAMPLE + 1)
    u = np.modf(k * GOLDEN)[0]                   # in [0, 1), equidistributed
    v = np.modf(k * SQRT2)[0]                    # another, independent of u
    if kind == "pairs":
        return -10.0 + 20.0 * u, -10.0 + 20.0 * v
    if kind == "unit":
        return (-1.0 + 2.0 * u,)
    if kind == "positive":
        return (np.exp(-20.0 + 40.0 * u),)
    if kind == "narrow":
        return (-30.0 + 60.0 * u,)
    return (np.where(v < 0.5, -7.0 + 14.0 * u, -1e3 + 2e3 * u),)


@lru_cache(maxsize=None)
def agrees(name: str) -> bool:
    """Whether NumPy's ``name`` gives the C library's values to the bit on a fixed sample of
    its arguments (in this process, on this machine)."""
    if name not in CHECKED:
        return False
    reference, kind = CHECKED[name]
    args = _arguments(kind)
    with np.errstate(all="ignore"):
        mine = getattr(np, name)(*args)
    theirs = np.array([_or_nan(reference, values) for values in zip(*(a.tolist() for a in args))])
    same = bool(np.array_equal(mine, theirs, equal_nan=True))
    if not same:
        user_cache.log.debug("NumPy's %s is not the C library's here: functions that use it "
                             "run on the NumPy lanes", name)
    return same


def _or_nan(reference, values) -> float:
    """``reference(*values)``, NaN outside its domain (where NumPy gives NaN)."""
    try:
        return reference(*values)
    except (ValueError, OverflowError):
        return math.nan


def eligible(functions: set[str]) -> bool:
    """Whether a compiled loop gives the NumPy lanes' values to the bit for a kernel that
    calls these NumPy ``functions`` (the names its code reads)."""
    if any(f in functions for f in NEVER):
        return False
    return all(agrees(f) for f in functions if f in CHECKED)


class Native:
    """A loaded lanes library: ``native(arrays, outs, first, last)`` fills lanes ``first`` to
    ``last`` - 1 of ``outs`` (C-ordered (rows, lanes) arrays) from ``arrays`` (C-ordered
    (rows, 1 or lanes) arrays), letting go of the interpreter while it runs."""

    def __init__(self, path: Path, digest: str):
        #: the library's file, and the digest of its recipe (:func:`recipe`)
        self.path, self.digest = path, digest
        run = ctypes.CDLL(str(path)).optdesign_lanes
        run.restype = ctypes.c_int
        run.argtypes = [ctypes.POINTER(ctypes.c_void_p), ctypes.POINTER(ctypes.c_longlong),
                        ctypes.POINTER(ctypes.c_void_p), ctypes.c_longlong, ctypes.c_longlong,
                        ctypes.c_longlong]
        self._run = run

    def __call__(self, arrays: list[np.ndarray], outs: list[np.ndarray], first: int,
                 last: int) -> None:
        lanes = outs[0].shape[1] if outs else 0
        pointers = (ctypes.c_void_p * max(len(arrays), 1))(*[a.ctypes.data for a in arrays])
        cols = (ctypes.c_longlong * max(len(arrays), 1))(*[a.shape[1] for a in arrays])
        results = (ctypes.c_void_p * max(len(outs), 1))(*[o.ctypes.data for o in outs])
        flag = self._run(pointers, cols, results, lanes, first, last)
        if flag != 0:
            raise MemoryError(f"{self.path.name}: the compiled lanes returned {flag}")


def load(fn: ca.Function, serialized: str | None, where: Path | None,
         functions: set[str]) -> Native | None:
    """``fn``'s compiled lanes from the user's cache folder ``where`` (the one the NumPy
    kernel's code is kept in: None under ``OPTDESIGN_COMPILE=off`` or without a folder of the
    user's own), or None: no folder, a function CasADi cannot write (``serialized`` None), a
    function whose values the C library would change (:func:`eligible`), or no library yet
    (under ``on``, its build is started beside)."""
    if serialized is None or where is None or not eligible(functions):
        return None
    rec = recipe(fn, serialized)
    path = c_library.library(rec, where)
    if path is None:
        if user_cache.mode() == "on":
            c_library.start(rec, where)
        return None
    native = _loaded(path, rec.digest)
    if native is not None:
        user_cache.log.debug("%s: compiled lanes %s", fn.name(), path)
    return native


def load_named(digest: str, where: Path, functions: set[str]) -> Native | None:
    """:func:`load` of the library of the recipe ``digest`` (:func:`recipe`), from its digest
    alone (:meth:`optdesign.numerics.lanes.Lanes.restored`), or None: a function whose values
    the C library would change, or no library intact in ``where`` (no build is started:
    the caller builds from the function)."""
    if not eligible(functions):
        return None
    path = c_library.library_named(where, digest, "lanes")
    return None if path is None else _loaded(path, digest)


def _loaded(path: Path, digest: str) -> Native | None:
    try:
        return Native(path, digest)
    except (OSError, AttributeError) as exc:    # not loadable, or no driver: the NumPy lanes
        user_cache.log.debug("%s not loaded (%s)", path, exc)
        return None

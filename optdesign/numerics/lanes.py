"""NumPy lanes for a CasADi SX function: one call evaluates it at many inputs at once.

``Function.map`` evaluates an SX function input by input in CasADi's virtual machine, a few
nanoseconds per instruction per input. Screening thousands of designs at hundreds of crank
angles calls the same few thousand instructions a hundred thousand times, so the instruction
list is turned once into NumPy statements, each applied to a whole array of inputs ("lanes")
at once: the same arithmetic in the same order, at a fraction of the cost. The elementary
operations are correctly rounded, so they give CasADi's values bit for bit; NumPy's elementary
functions (arccos, arctan2, exp, ...) are the C library's on some machines and NumPy's own
SIMD kernels on others (AVX-512), which can differ in the last bit, so the values agree with
CasADi's to a few units in the last place (``tests/test_lanes.py``).

Only scalar SX instructions are translated; a function holding anything else (a call, a
matrix operation) raises :class:`NotImplementedError` at construction, and the caller keeps
``map``.

Every lane is computed on its own (elementwise), so how the lanes are cut into passes changes
no value. A call of many passes shares them between :func:`threads` (NumPy's ufuncs let go of
the interpreter while they compute): the same values to the bit, in about two thirds of the
time on two cores (the statements' interpreter work is done by one thread at a time), where
the caller owns them (a solve whose polishes may use every core; not a sweep's
or an atlas's worker, one of several processes).

Translating and compiling the statements takes a tenth of a second for the kinematics of 24
chains, in every new process; the compiled code is kept in the user's cache folder
(:mod:`optdesign.numerics.user_cache`), named by a digest of the function as CasADi
serialises it, of this module's own text and of the Python that compiled it: a later process
loads the very same code (a millisecond), so the values are the same to the bit.

Where the same function compiled to C is in the cache, and gives these statements' values to
the bit (:mod:`optdesign.numerics.native_lanes`), a call runs it instead: up to 5 times
faster, and a call shared between two threads runs on both cores at once.
"""
from __future__ import annotations

import hashlib
import importlib.util
import marshal
import sys
import threading
import types
from contextlib import contextmanager
from contextvars import ContextVar
from functools import lru_cache
from pathlib import Path

import casadi as ca
import numpy as np

from optdesign.numerics import native_lanes, user_cache

#: lanes per pass: the work arrays of one pass stay in the processor's cache
CHUNK = 4096
#: lanes per pass where two threads share the passes: longer passes, so that the interpreter's
#: share of a statement (held by one thread at a time) is smaller beside the arithmetic
THREADED_CHUNK = 8192
#: the work (lanes × the function's instructions) from which a call of the compiled lanes
#: shares its lanes between two threads: each half runs on a core of its own, without the
#: interpreter, which pays a thread's start from about a millisecond of work on (a design's
#: exact grid of the four-bar's kinematics at 6 phases: 1024 lanes × 1780 instructions;
#: ``benchmarks/lanes_compiled.py``)
NATIVE_SHARED_WORK = 1_000_000
#: the threads a call may use (:func:`threads`)
_THREADS: ContextVar[int] = ContextVar("lanes_threads", default=1)
#: a cached kernel's trailer tag (:func:`optdesign.numerics.user_cache.trailer`)
CACHE_TAG = "optdesign-lanes"

_UNARY = {
    "OP_ASSIGN": "{0}", "OP_NEG": "-{0}", "OP_SQ": "{0} * {0}", "OP_TWICE": "2.0 * {0}",
    "OP_INV": "1.0 / {0}", "OP_SQRT": "np.sqrt({0})", "OP_FABS": "np.abs({0})",
    "OP_SIN": "np.sin({0})", "OP_COS": "np.cos({0})", "OP_TAN": "np.tan({0})",
    "OP_ASIN": "np.arcsin({0})", "OP_ACOS": "np.arccos({0})", "OP_ATAN": "np.arctan({0})",
    "OP_SINH": "np.sinh({0})", "OP_COSH": "np.cosh({0})", "OP_TANH": "np.tanh({0})",
    "OP_ASINH": "np.arcsinh({0})", "OP_ACOSH": "np.arccosh({0})",
    "OP_ATANH": "np.arctanh({0})", "OP_EXP": "np.exp({0})", "OP_LOG": "np.log({0})",
    "OP_EXPM1": "np.expm1({0})", "OP_LOG1P": "np.log1p({0})", "OP_FLOOR": "np.floor({0})",
    "OP_CEIL": "np.ceil({0})", "OP_SIGN": "np.sign({0})", "OP_ERF": "special.erf({0})",
    "OP_NOT": "np.logical_not({0}).astype(float)",
}
_BINARY = {
    "OP_ADD": "{0} + {1}", "OP_SUB": "{0} - {1}", "OP_MUL": "{0} * {1}",
    "OP_DIV": "{0} / {1}", "OP_POW": "np.power({0}, {1})",
    "OP_CONSTPOW": "np.power({0}, {1})", "OP_ATAN2": "np.arctan2({0}, {1})",
    "OP_HYPOT": "np.hypot({0}, {1})", "OP_FMIN": "np.fmin({0}, {1})",
    "OP_FMAX": "np.fmax({0}, {1})", "OP_FMOD": "np.fmod({0}, {1})",
    "OP_COPYSIGN": "np.copysign({0}, {1})",
    "OP_LT": "np.less({0}, {1}).astype(float)", "OP_LE": "np.less_equal({0}, {1}).astype(float)",
    "OP_EQ": "np.equal({0}, {1}).astype(float)", "OP_NE": "np.not_equal({0}, {1}).astype(float)",
    "OP_AND": "np.logical_and({0}, {1}).astype(float)",
    "OP_OR": "np.logical_or({0}, {1}).astype(float)",
    "OP_IF_ELSE_ZERO": "np.where({0} != 0, {1}, 0.0)",
}
_NAMES = {getattr(ca, name): name for name in dir(ca) if name.startswith("OP_")}


class Lanes:
    """``fn`` (an SX :class:`casadi.Function` of dense column inputs) evaluated lane-wise.

    ``lanes(*args)``: each argument an array of shape (rows of that input, L) or (rows, 1)
    (the same value in every lane); returns one (rows of that output, L) array per output.
    """

    def __init__(self, fn: ca.Function, serialized: str | None = None):
        """``serialized``: ``fn`` as CasADi writes it, where the caller has it (else written
        here, unless ``OPTDESIGN_COMPILE=off``)."""
        if not fn.is_a("SXFunction"):
            raise NotImplementedError(f"{fn.name()} is not an SX function")
        self.fn, self.name = fn, fn.name()
        self.n_in = fn.n_in()
        self.sizes_in = [fn.nnz_in(i) for i in range(fn.n_in())]
        self.sizes_out = [fn.nnz_out(i) for i in range(fn.n_out())]
        self.instructions = fn.n_instructions()
        for i in range(fn.n_in()):
            if not fn.sparsity_in(i).is_dense() or fn.size2_in(i) != 1:
                raise NotImplementedError(f"{fn.name()}: input {i} is not a dense column")
        text = _serialized(fn) if serialized is None or user_cache.mode() == "off" \
            else serialized
        where, self._digest = _cache_of(text)
        self._kernel = _compile(fn, where, self._digest)
        #: the same function compiled to C, where it is cached and gives the same bits
        #: (:mod:`optdesign.numerics.native_lanes`); else None and the NumPy kernel runs
        self.native = native_lanes.load(fn, text, where, set(self._kernel.__code__.co_names))
        #: whether these lanes are all a record names (:meth:`record`): their code kept in
        #: the cache folder, and the compiled loop loaded wherever one may run
        self._whole = where is not None and (
            self.native is not None or
            not native_lanes.eligible(set(self._kernel.__code__.co_names)))

    def record(self) -> dict | None:
        """What :meth:`restored` makes these lanes again from, in a later process, without
        their function: its name and sizes, the digests of its kept code and of its compiled
        loop; None where either is not in the cache folder (a record would run a later
        process without the loop it may build)."""
        if not self._whole:
            return None
        return {"name": self.name, "sizes_in": self.sizes_in, "sizes_out": self.sizes_out,
                "instructions": self.instructions, "code": self._digest,
                "native": None if self.native is None else self.native.digest}

    @classmethod
    def restored(cls, record: dict) -> "Lanes | None":
        """The lanes a :meth:`record` names, from the user's cache folder: the same code
        and the same compiled loop, so the same values to the bit; None where the folder no
        longer holds both as they were kept, or a loop that may run is not there."""
        where = user_cache.in_use()
        code = _cached(where, record["code"]) if where is not None else None
        if code is None:
            return None
        kernel = _kernel_of(code)
        functions = set(kernel.__code__.co_names)
        native = None
        if record["native"] is not None:
            native = native_lanes.load_named(record["native"], where, functions)
            if native is None:
                return None
        elif native_lanes.eligible(functions):
            return None                         # a loop may run here: built from the function
        lanes = cls.__new__(cls)
        lanes.fn, lanes.name = None, str(record["name"])
        lanes.sizes_in = [int(k) for k in record["sizes_in"]]
        lanes.sizes_out = [int(k) for k in record["sizes_out"]]
        lanes.n_in, lanes.instructions = len(lanes.sizes_in), int(record["instructions"])
        lanes._digest, lanes._kernel, lanes.native = record["code"], kernel, native
        lanes._whole = True
        return lanes

    def __call__(self, *args) -> list[np.ndarray]:
        if len(args) != self.n_in:
            raise TypeError(f"{self.name} takes {self.n_in} inputs, got {len(args)}")
        arrays = [np.atleast_2d(np.asarray(a, dtype=float)) for a in args]
        for i, (a, rows) in enumerate(zip(arrays, self.sizes_in)):
            if a.shape[0] != rows:
                raise ValueError(f"{self.name}: input {i} has {a.shape[0]} rows, "
                                 f"expected {rows}")
        L = max(a.shape[1] for a in arrays) if arrays else 1
        outs = [np.empty((rows, L)) for rows in self.sizes_out]
        if self.native is not None:
            shared = _THREADS.get() > 1 and L * self.instructions >= NATIVE_SHARED_WORK
            for i, a in enumerate(arrays):
                if a.shape[1] not in (1, L):
                    raise ValueError(f"{self.name}: input {i} has {a.shape[1]} lanes, "
                                     f"expected 1 or {L}")
            arrays = [np.ascontiguousarray(a) for a in arrays]
            # two threads at once where the caller owns the cores: ctypes lets go of the
            # interpreter, so each half of the lanes runs on a core of its own
            parts = [(0, L // 2), (L // 2, L)] if shared else [(0, L)]

            def passes(mine):
                for first, last in mine:
                    self.native(arrays, outs, first, last)
        else:
            shared = _THREADS.get() > 1 and L > THREADED_CHUNK
            step = THREADED_CHUNK if shared else CHUNK
            parts = [slice(start, min(start + step, L)) for start in range(0, L, step)]

            def passes(mine):
                with np.errstate(all="ignore"):
                    for part in mine:
                        ins = [a if a.shape[1] == 1 else a[:, part] for a in arrays]
                        self._kernel(ins, [o[:, part] for o in outs])

        if not shared:
            passes(parts)
            return outs
        failed: list[BaseException] = []

        def helper():
            try:
                passes(parts[1::2])
            except BaseException as exc:      # raised again in the caller's thread
                failed.append(exc)

        other = threading.Thread(target=helper, name="lanes", daemon=True)
        other.start()
        try:
            passes(parts[0::2])
        finally:
            other.join()
        if failed:
            raise failed[0]
        return outs


@contextmanager
def threads(count: int):
    """Inside, a call made by this thread with more than one pass shares its passes between
    two threads where ``count`` > 1 (the caller's cores are free for it); the values are the
    same to the bit. A thread started inside begins with one thread, as everywhere else."""
    token = _THREADS.set(max(1, int(count)))
    try:
        yield
    finally:
        _THREADS.reset(token)


def _compile(fn: ca.Function, where: Path | None, digest: str):
    """The instruction list as the body of one Python function over NumPy arrays (its code
    from the user's cache folder ``where`` where it is kept there under ``digest``, else
    compiled and kept: :func:`_cache_of`)."""
    code = _cached(where, digest)
    if code is None:
        code = compile(_source(fn), f"<lanes {fn.name()}>", "exec")
        if where is not None:
            _keep(where, digest, code)
    return _kernel_of(code)


def _kernel_of(code: types.CodeType):
    """The kernel function :func:`_compile`'s ``code`` defines."""
    namespace = {"np": np}
    kernel = next(c for c in code.co_consts if isinstance(c, types.CodeType))
    if "special" in kernel.co_names:         # erf alone needs scipy (0.2 s to import)
        from scipy import special
        namespace["special"] = special
    exec(code, namespace)
    return namespace["kernel"]


def _source(fn: ca.Function) -> str:
    """The Python text of :func:`_compile`'s function."""
    body = []
    for k in range(fn.n_instructions()):
        op = _NAMES.get(fn.instruction_id(k), str(fn.instruction_id(k)))
        args, res = fn.instruction_input(k), fn.instruction_output(k)
        if op == "OP_INPUT":
            body.append(f"w{res[0]} = a[{args[0]}][{args[1]}]")
        elif op == "OP_OUTPUT":
            body.append(f"o[{res[0]}][{res[1]}] = w{args[0]}")
        elif op == "OP_CONST":
            body.append(f"w{res[0]} = {_literal(float(fn.instruction_constant(k)))}")
        elif op in _UNARY:
            body.append(f"w{res[0]} = " + _UNARY[op].format(f"w{args[0]}"))
        elif op in _BINARY:
            body.append(f"w{res[0]} = " + _BINARY[op].format(f"w{args[0]}", f"w{args[1]}"))
        else:
            raise NotImplementedError(f"{fn.name()}: instruction {op} has no NumPy lane form")
    return "def kernel(a, o):\n" + "".join(f"    {line}\n" for line in body or ["pass"])


@lru_cache(maxsize=1)
def _translator() -> bytes:
    """What the code depends on besides the function: this module's text (its translation
    tables) and the Python that compiles it (its bytecode's magic number)."""
    return hashlib.sha256(Path(__file__).read_bytes()).digest() + \
        importlib.util.MAGIC_NUMBER + sys.version.encode()


def _serialized(fn: ca.Function) -> str | None:
    """``fn`` as CasADi writes it (what its kept code is named by), or None: under
    ``OPTDESIGN_COMPILE=off``, or a function CasADi cannot write (compiled each time)."""
    if user_cache.mode() == "off":
        return None
    try:
        return fn.serialize()
    except RuntimeError as exc:
        user_cache.log.debug("%s not kept (%s)", fn.name(), exc)
        return None


def _cache_of(text: str | None) -> tuple[Path | None, str]:
    """(the cache folder, the digest of the code of the function serialised as ``text``);
    no folder without a text, under ``OPTDESIGN_COMPILE=off`` or where the user has none."""
    where = user_cache.in_use() if text is not None else None
    if where is None:
        return None, ""
    return where, hashlib.sha256(_translator() + text.encode()).hexdigest()


def _name(digest: str) -> str:
    return f"lanes-{digest[:40]}.marshal"


def _cached(where: Path | None, digest: str) -> types.CodeType | None:
    """The kept code of ``digest``, or None (none kept, or a file not to be trusted)."""
    body = user_cache.kept(where, _name(digest), CACHE_TAG, digest)
    if body is None:
        return None
    try:
        code = marshal.loads(body)
    except (EOFError, ValueError, TypeError):
        return None
    return code if isinstance(code, types.CodeType) else None


def _keep(where: Path, digest: str, code: types.CodeType) -> None:
    """``code`` into the cache (a failure costs the next process the compile alone)."""
    user_cache.keep(where / _name(digest), CACHE_TAG, digest, marshal.dumps(code))


def _literal(value: float) -> str:
    if np.isfinite(value):
        return repr(value)
    return "np.nan" if np.isnan(value) else ("np.inf" if value > 0 else "-np.inf")

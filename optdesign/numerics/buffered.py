"""Calls of a CasADi function through bound NumPy buffers: the exact evaluator's inner loop.

``casadi.Function.__call__`` converts every argument and every result through SWIG's
typemaps, which costs several times the arithmetic of a one-chain SX function, and the exact
evaluator's root searches make thousands of single-angle calls per design.
``Function.buffer()`` binds NumPy arrays to the function's inputs and outputs once; a call
then writes the inputs in place, evaluates and copies the outputs out. The arithmetic is
CasADi's own, so the results are bit-identical to ``Function.call`` (tests/test_buffered.py).

A buffer is state: every thread keeps its own (:func:`buffered`).
"""
from __future__ import annotations

import threading

import numpy as np

#: at most this many bound functions per thread (the mechanisms' caches hold fewer)
MAX_BOUND = 512

_local = threading.local()


class BufferedCall:
    """``function`` with dense inputs, called on NumPy values.

    ``call(*args)`` takes one value per input (a float, or a vector of the input's entries in
    column-major order) and returns every output's entries, dense and column-major,
    concatenated in one vector (a structurally zero entry, e.g. d cos μ/dφ of a mechanism whose
    cos μ does not move, reads 0).
    """

    def __init__(self, function):
        for i in range(function.n_in()):
            if not function.sparsity_in(i).is_dense():
                raise ValueError(f"{function.name()}: input {i} is sparse")
        self.function = function
        self._inputs = [np.zeros(function.nnz_in(i)) for i in range(function.n_in())]
        nonzeros, positions, offset = [], [], 0
        for i in range(function.n_out()):
            sparsity = function.sparsity_out(i)
            nonzeros.append(function.nnz_out(i))
            positions.append(offset + np.asarray(sparsity.find(), dtype=int))
            offset += sparsity.numel()
        self._size = offset
        self._dense = all(k == function.numel_out(i) for i, k in enumerate(nonzeros))
        self._positions = np.concatenate(positions) if positions else np.zeros(0, int)
        self._nz = np.zeros(sum(nonzeros))
        starts = np.concatenate([[0], np.cumsum(nonzeros)]).astype(int)
        self._buffer, self._evaluate = function.buffer()
        # the views must outlive the buffer's pointers into them
        self._views = [memoryview(a) for a in self._inputs] + [
            memoryview(self._nz[a:b]) for a, b in zip(starts[:-1], starts[1:])]
        for i, view in enumerate(self._views[:len(self._inputs)]):
            self._buffer.set_arg(i, view)
        for i, view in enumerate(self._views[len(self._inputs):]):
            self._buffer.set_res(i, view)

    def __call__(self, *args) -> np.ndarray:
        if len(args) != len(self._inputs):
            raise TypeError(f"{self.function.name()}: {len(self._inputs)} inputs, "
                            f"{len(args)} given")
        for target, value in zip(self._inputs, args):
            target[:] = value
        self._evaluate()
        if self._dense:
            return self._nz.copy()
        out = np.zeros(self._size)
        out[self._positions] = self._nz
        return out


def buffered(function) -> BufferedCall:
    """This thread's :class:`BufferedCall` of ``function`` (made on first use)."""
    calls = _local.__dict__.setdefault("calls", {})
    call = calls.get(id(function))
    if call is None or call.function is not function:
        if len(calls) >= MAX_BOUND:
            calls.clear()
        call = calls[id(function)] = BufferedCall(function)
    return call

"""Lanes of a function whose first output is a column of angles θ_k = atan2(y_k, x_k): the
rest on the lanes, the angles taken by NumPy from the lanes' y_k and x_k.

A mechanism's kinematics (θ, dθ/dφ, d²θ/dφ², cos μ) holds an atan2 per rocker, its angle θ_k;
the derivatives of an angle are rational in its two legs. On machines where NumPy's arctan2 is
its own SIMD kernel (AVX-512), which differs from the C library's in the last bit, a function
with an atan2 in it never runs on the compiled lanes (:mod:`optdesign.numerics.native_lanes`),
and the exact evaluator's grids stay on the NumPy lanes. Here the lanes evaluate (y, x, dθ/dφ,
d²θ/dφ², cos μ) and ``np.arctan2(y, x)`` makes θ: the very operations the NumPy lanes of the
whole function make, on the same operands, so the same values to the bit whichever loop ran
(``tests/test_angle_lanes.py``). Where nothing else in the function takes an atan2 (the slotted
lever's kinematics) the legs run compiled there; the four-bar's pins turn with the coupler's
angle, an atan2 inside, and its legs stay on the NumPy lanes.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from optdesign.numerics.lanes import Lanes


class AngleLanes:
    """``fn`` (an SX :class:`casadi.Function` whose first output's every entry is an atan2)
    evaluated lane-wise as :class:`~optdesign.numerics.lanes.Lanes` evaluates it, the angles
    outside the lanes (see the module's text). :func:`angle_lanes` makes one, or plain lanes
    where ``fn`` is not of that form."""

    def __init__(self, fn: ca.Function, legs: ca.Function):
        self.fn = fn
        #: (y, x, the other outputs): the function the lanes evaluate
        self.legs = Lanes(legs)
        self.instructions = self.legs.instructions

    @property
    def native(self):
        """The legs' compiled loop (None: the NumPy statements run)."""
        return self.legs.native

    @native.setter
    def native(self, loop) -> None:
        self.legs.native = loop

    def __call__(self, *args) -> list[np.ndarray]:
        y, x, *rest = self.legs(*args)
        with np.errstate(all="ignore"):
            return [np.arctan2(y, x), *rest]


def angle_lanes(fn: ca.Function):
    """:class:`AngleLanes` of ``fn`` where its first output is a dense column of atan2 entries
    (:func:`legs_of`), else :class:`~optdesign.numerics.lanes.Lanes` of ``fn`` itself."""
    legs = legs_of(fn)
    return Lanes(fn) if legs is None else AngleLanes(fn, legs)


def legs_of(fn: ca.Function) -> ca.Function | None:
    """``fn`` with its first output, a dense column of atan2(y_k, x_k) entries, replaced by
    the two columns y and x (read off each entry's operands), the others as they are: the
    function :class:`AngleLanes` runs on the lanes. None where ``fn`` is not of that form (not
    an SX function, or an angle that is not an atan2)."""
    if not fn.is_a("SXFunction") or fn.n_out() < 1:
        return None
    inputs = fn.sx_in()
    outputs = fn.call(inputs, True, False)
    angles = outputs[0]
    if not angles.sparsity().is_dense() or angles.size2() != 1 or angles.numel() == 0:
        return None
    entries = [angles[k] for k in range(angles.numel())]
    if not all(e.op() == ca.OP_ATAN2 for e in entries):
        return None
    y = ca.vertcat(*[e.dep(0) for e in entries])
    x = ca.vertcat(*[e.dep(1) for e in entries])
    return ca.Function(f"{fn.name()}_legs", inputs, [y, x, *outputs[1:]])

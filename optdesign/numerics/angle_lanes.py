"""Lanes of a function with atan2 in it: the rest on the lanes, every atan2 taken by NumPy
between stages of them.

A mechanism's kinematics (θ, dθ/dφ, d²θ/dφ², cos μ) holds an atan2 per rocker, its angle θ_k
(the derivatives of an angle are rational in its two legs), and the four-bar's one more inside:
the coupler's angle φ2 of eq. (4) of Sharkov & Kalinin (2022), which every rocker's pins turn
with. On machines where NumPy's arctan2 is its own SIMD kernel (AVX-512), which differs from the
C library's in the last bit, a function with an atan2 in it never runs on the compiled lanes
(:mod:`optdesign.numerics.native_lanes`), and the exact evaluator's grids would stay on the
NumPy lanes. So the function is cut at its atan2 (:func:`split`): stage 1 evaluates the legs
(y, x) of the atan2 that take no other, ``np.arctan2`` makes their angles, stage 2 is given
them and evaluates the legs of the next, and so on; the last stage evaluates the outputs, an
output that is an atan2 of that stage's level taken by NumPy from its legs. Each stage makes
the very operations the NumPy lanes of the whole function make, on the same operands, so the
values are the same to the bit whichever loop ran each stage (``tests/test_angle_lanes.py``),
and stages free of atan2 run compiled where sine and cosine agree with the C library's.

The stages are rebuilt instruction by instruction from the function's algorithm, once per
function: they are kept in the user's cache folder as CasADi writes them, named by a digest of
the function, of this module's text and of CasADi's version, so a later process reads them
instead.
Under ``OPTDESIGN_COMPILE=off`` (no cache folder in use, nothing compiled) the whole function
runs on the NumPy lanes: the same values.
"""
from __future__ import annotations

import hashlib
import json
from functools import lru_cache
from pathlib import Path
from typing import NamedTuple

import casadi as ca
import numpy as np

from optdesign.numerics import user_cache
from optdesign.numerics.lanes import Lanes

#: a kept split's trailer tag (:func:`optdesign.numerics.user_cache.trailer`)
CACHE_TAG = "optdesign-angle-stages"


class Split(NamedTuple):
    """A function cut at its atan2 (:func:`split`)."""

    #: stage s: (the function's inputs, then the angles of stages 1 .. s-1, a column per
    #: stage) -> (y, x: the legs of stage s's angles, then, in the last stage only, the
    #: function's outputs with each output of the last stage's angles in its y leg's place)
    stages: tuple[ca.Function, ...]
    #: (output, nonzero, angle of the last stage) of every output entry the last stage's
    #: angles fill
    places: tuple[tuple[int, int, int], ...]
    #: each stage as CasADi writes it (what its lanes' kept code is named by)
    texts: tuple[str, ...]


class AngleLanes:
    """``fn`` evaluated lane-wise as :class:`~optdesign.numerics.lanes.Lanes` evaluates it,
    every atan2 outside the lanes between the stages of its :class:`Split` (see the module's
    text). :func:`angle_lanes` makes one, or plain lanes where ``fn`` has no atan2."""

    def __init__(self, fn: ca.Function | None, cut: Split | None, stages=None):
        """The lanes of ``cut``'s stages (or ``stages``, those lanes already made, with
        ``cut``'s places: :meth:`restored`)."""
        self.fn = fn
        #: each stage's lanes
        self.stages = stages if stages is not None else \
            [Lanes(stage, text) for stage, text in zip(cut.stages, cut.texts)]
        self.places = cut.places
        self.instructions = sum(s.instructions for s in self.stages)

    def record(self) -> dict | None:
        """What :meth:`restored` makes these lanes again from (each stage's
        :meth:`~optdesign.numerics.lanes.Lanes.record` and the places), or None where a
        stage has none."""
        stages = [s.record() for s in self.stages]
        if any(r is None for r in stages):
            return None
        return {"stages": stages, "places": [list(p) for p in self.places]}

    @classmethod
    def restored(cls, record: dict) -> "AngleLanes | None":
        """The lanes a :meth:`record` names (None where a stage's are not to be had)."""
        stages = [Lanes.restored(r) for r in record["stages"]]
        if any(s is None for s in stages):
            return None
        places = tuple(tuple(int(k) for k in p) for p in record["places"])
        return cls(None, Split((), places, ()), stages)

    @property
    def native(self):
        """The stages' compiled loops, a tuple (None where no stage has one: the NumPy
        statements run)."""
        loops = tuple(s.native for s in self.stages)
        return None if all(loop is None for loop in loops) else loops

    @native.setter
    def native(self, loops) -> None:
        for stage, loop in zip(self.stages, loops or (None,) * len(self.stages)):
            stage.native = loop

    def __call__(self, *args) -> list[np.ndarray]:
        angles = []
        for stage in self.stages[:-1]:
            y, x = stage(*args, *angles)
            angles.append(_arctan2(y, x))
        y, x, *outs = self.stages[-1](*args, *angles)
        if self.places:
            last = _arctan2(y, x)
            for output, nonzero, angle in self.places:
                outs[output][nonzero] = last[angle]
        return outs


def _arctan2(y: np.ndarray, x: np.ndarray) -> np.ndarray:
    with np.errstate(all="ignore"):
        return np.arctan2(y, x)


def angle_lanes(fn: ca.Function):
    """:class:`AngleLanes` of ``fn`` cut at its atan2 (:func:`kept_split`), else
    :class:`~optdesign.numerics.lanes.Lanes` of ``fn`` itself (no atan2, a function the cut
    cannot read, or no cache folder in use)."""
    cut = kept_split(fn)
    return Lanes(fn) if cut is None else AngleLanes(fn, cut)


def lane_functions(fn: ca.Function) -> list[tuple[ca.Function, str]]:
    """(function, as CasADi writes it) of every function :func:`angle_lanes` of ``fn`` runs
    on lanes: what a warm-up compiles."""
    cut = kept_split(fn)
    return [(fn, fn.serialize())] if cut is None else list(zip(cut.stages, cut.texts))


def kept_split(fn: ca.Function) -> Split | None:
    """:func:`split` of ``fn``, read from the user's cache folder where it is kept there, else
    made and kept; None under ``OPTDESIGN_COMPILE=off``, without a folder of the user's own,
    or where :func:`split` gives none."""
    where = user_cache.in_use()
    if where is None or not fn.is_a("SXFunction"):
        return None
    try:
        text = fn.serialize()
    except RuntimeError:
        return None
    digest = hashlib.sha256(_maker() + text.encode()).hexdigest()
    name = f"angle-stages-{digest[:40]}.json"
    body = user_cache.kept(where, name, CACHE_TAG, digest)
    if body is not None:
        try:
            kept = json.loads(body)
            if kept["stages"] is None:          # no atan2 in it: its plain lanes
                return None
            return Split(tuple(ca.Function.deserialize(t) for t in kept["stages"]),
                         tuple(tuple(p) for p in kept["places"]), tuple(kept["stages"]))
        except (ValueError, KeyError, TypeError, RuntimeError):
            pass                                # not to be read: made again and kept
    cut = split(fn)
    if cut is None:
        body = json.dumps({"stages": None}).encode()
    else:
        body = json.dumps({"stages": list(cut.texts), "places": cut.places}).encode()
    user_cache.keep(where / name, CACHE_TAG, digest, body)
    return cut


@lru_cache(maxsize=1)
def _maker() -> bytes:
    """What a kept split depends on besides the function: this module's text (the cut) and
    CasADi's version (how it writes and reads functions)."""
    return hashlib.sha256(Path(__file__).read_bytes()).digest() + ca.__version__.encode()


def split(fn: ca.Function) -> Split | None:
    """``fn`` (an SX function of dense column inputs) cut at its atan2: its algorithm rebuilt
    instruction by instruction, each atan2 replaced by a symbol of its own, the angle, whose
    stage is one more than the latest stage of the angles its legs take. None where ``fn`` has
    no atan2, or an instruction that is not a scalar operation."""
    inputs = [ca.SX.sym(f"i{i}", fn.nnz_in(i)) for i in range(fn.n_in())]
    entries = [[inputs[i][k] for k in range(fn.nnz_in(i))] for i in range(fn.n_in())]
    value, stage, angle_at = {}, {}, {}        # by work slot: expression, stage, angle
    angles = []                                 # (symbol, y, x, stage)
    outputs = [[None] * fn.nnz_out(i) for i in range(fn.n_out())]
    for k in range(fn.n_instructions()):
        op, args, res = fn.instruction_id(k), fn.instruction_input(k), fn.instruction_output(k)
        if op == ca.OP_OUTPUT:
            outputs[res[0]][res[1]] = (value[args[0]], stage[args[0]], angle_at.get(args[0]))
            continue
        slot = res[0]
        angle_at.pop(slot, None)
        if op == ca.OP_INPUT:
            value[slot], stage[slot] = entries[args[0]][args[1]], 0
        elif op == ca.OP_CONST:
            value[slot], stage[slot] = ca.SX(fn.instruction_constant(k)), 0
        elif op == ca.OP_ATAN2:
            level = max(stage[args[0]], stage[args[1]]) + 1
            symbol = ca.SX.sym(f"angle{len(angles)}")
            angle_at[slot] = len(angles)
            angles.append((symbol, value[args[0]], value[args[1]], level))
            value[slot], stage[slot] = symbol, level
        elif len(args) == 1:
            value[slot], stage[slot] = ca.SX.unary(op, value[args[0]]), stage[args[0]]
        elif len(args) == 2:
            value[slot] = ca.SX.binary(op, value[args[0]], value[args[1]])
            stage[slot] = max(stage[args[0]], stage[args[1]])
        else:
            return None
    if not angles:
        return None
    # the last stage: that of the latest angle, or one after the latest stage of angles any
    # other output takes
    last = max([a[3] for a in angles] + [s + 1 for column in outputs
                                         for _, s, j in column if j is None])
    stages, given, places = [], [], []
    for s in range(1, last + 1):
        mine = [j for j, a in enumerate(angles) if a[3] == s]
        made = [_column([angles[j][1] for j in mine]), _column([angles[j][2] for j in mine])]
        if s == last:
            position = {j: q for q, j in enumerate(mine)}
            for i, column in enumerate(outputs):
                entries_out = []
                for nz, (expr, _, j) in enumerate(column):
                    if j is not None and angles[j][3] == last:
                        places.append((i, nz, position[j]))
                        expr = angles[j][1]             # a place held, filled by NumPy
                    entries_out.append(expr)
                made.append(_column(entries_out))
        stages.append(ca.Function(f"{fn.name()}_stage{s}", inputs + given, made))
        given.append(_column([angles[j][0] for j in mine]))
    return Split(tuple(stages), tuple(places), tuple(f.serialize() for f in stages))


def _column(entries: list) -> ca.SX:
    return ca.vertcat(*entries) if entries else ca.SX(0, 1)

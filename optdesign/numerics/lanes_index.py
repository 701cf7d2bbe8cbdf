"""What a mechanism's lanes are, kept on disk: a later process makes them without their
function.

A solve's screening runs its mechanism's speeds on lanes (:mod:`optdesign.numerics.lanes`),
its exact checks the kinematics cut at every atan2 (:mod:`optdesign.numerics.angle_lanes`).
Made in a new process, each is built from its function: the speeds' own symbolic model, the
function written as CasADi serialises it (what names its kept code and its compiled loop:
5 ms for the kinematics of 24 chains) and, for the kinematics, its stages read back from
their serialised text (6 ms). Once made, lanes need none of that: their sizes and the
digests of their code and of their loop, which the user's cache folder holds. Those are kept
here, as a record named by what the function is made from:

* the mechanism (its registered name and its class), which function (the kinematics or the
  speeds), the count and the options;
* the code and the constants (:func:`optdesign.numerics.code_stamp.environment`: every file
  of the package, the versions, the machine). Not ``OPTDESIGN_COMPILE``: whether builds are
  started changes nothing a record names (it names only what is in the folder already).

A record is written only for lanes that are whole (their code kept, their compiled loop
loaded wherever one may run, :meth:`~optdesign.numerics.lanes.Lanes.record`), and read on
the cache folder's terms (:mod:`optdesign.numerics.user_cache`). Lanes made from one run
the very code and loop that those made from the function run: the same values to the bit
(``tests/test_lanes_index.py``). Where anything the record names is gone, or a loop may now
run that it does not name, the lanes are made from the function as before and the record
written again. A mechanism whose model is not the package's own (a test's stand-in, a
method replaced) is never recorded: the code stamp would not name it.
"""
from __future__ import annotations

import hashlib
import pickle

from optdesign.numerics import code_stamp, user_cache
from optdesign.numerics.angle_lanes import AngleLanes
from optdesign.numerics.lanes import Lanes

#: the record's layout: part of its name
FORMAT = 1
#: the records' trailer tag (:mod:`optdesign.numerics.user_cache`)
TAG = "optdesign-lanes-index"
#: the methods a mechanism's functions are made by: each must be the package's own
MADE_BY = ("symbolic", "chain_expressions", "screening_expressions", "kinematics", "speeds",
           "default_options")
#: records written more than this many days ago are removed as another is written, and at
#: most this many kept (two per count and options of each mechanism a process sweeps)
KEPT_DAYS = 30
KEPT_RECORDS = 256


def made(mechanism, kind: str, count: int, options: tuple, make):
    """The lanes of ``mechanism``'s function ``kind`` (``"kinematics"``, ``"speeds"``) at
    ``count`` and ``options``: from their record where it is kept and all it names is
    there, else ``make()`` (which may raise :class:`NotImplementedError`), recorded."""
    key = key_of(mechanism, kind, count, options)
    record = read(key)
    if record is not None:
        lanes = restored(record)
        if lanes is not None:
            return lanes
    lanes = make()
    if key is not None:
        kept = lanes.record()
        if kept is not None:
            write(key, {"angles": isinstance(lanes, AngleLanes), "lanes": kept})
    return lanes


def key_of(mechanism, kind: str, count: int, options: tuple) -> str | None:
    """The name of the record (a sha256 digest), or None where nothing is cached
    (``OPTDESIGN_COMPILE=off``, no folder of the user's own) or the mechanism's model is
    not the package's own."""
    if user_cache.in_use() is None or not _packaged(mechanism):
        return None
    cls = type(mechanism)
    digest = hashlib.sha256()
    for part in (FORMAT, code_stamp.environment(), cls.__module__, cls.__qualname__,
                 mechanism.name, kind, int(count), tuple(options)):
        digest.update(hashlib.sha256(pickle.dumps(part)).digest())
    return digest.hexdigest()


def _packaged(mechanism) -> bool:
    """Whether every method ``mechanism``'s functions are made by is the package's own (not
    replaced on the instance, nor defined outside the package)."""
    for name in MADE_BY:
        if name in vars(mechanism):
            return False
        method = getattr(type(mechanism), name, None)
        module = getattr(getattr(method, "__wrapped__", method), "__module__", None) or ""
        if not module.startswith("optdesign."):
            return False
    return True


def read(key: str | None) -> dict | None:
    """The record named ``key``, or None: none kept, or one not to be trusted or read."""
    return None if key is None else user_cache.read_record(_name(key), TAG, key, FORMAT)


def restored(record: dict):
    """The lanes ``record`` names, or None (a record not of this layout, or what it names
    not in the cache folder as it was kept)."""
    try:
        kind = AngleLanes if record["angles"] else Lanes
        return kind.restored(record["lanes"])
    except (KeyError, TypeError, ValueError):
        return None


def write(key: str, record: dict) -> None:
    """Keep ``record`` as ``key``'s (atomically; a failure costs the next process the
    function's build), and let go of old ones (:data:`KEPT_DAYS`, :data:`KEPT_RECORDS`)."""
    where = user_cache.write_record(_name(key), TAG, key, FORMAT, record)
    if where is not None:
        user_cache.let_go_of_old(where, "kept-lanes-", ".json", KEPT_DAYS, KEPT_RECORDS)


def _name(key: str) -> str:
    return f"kept-lanes-{key[:40]}.json"

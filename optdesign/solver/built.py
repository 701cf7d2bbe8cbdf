"""NLPs built once per process: a phase count's NLP, kept for every later solve of the same
problem.

Building an NLP (:class:`~optdesign.solver.nlp.PhaseNLP`: the CasADi graph, its derivatives
and IPOPT's function on them) costs 0.1-0.7 s, as much as several polishes; a second solve of
the same problem in one process (a notebook, the explorer, a Pareto sweep's points, a warm
benchmark) would pay it again. The NLPs are kept here, keyed by everything they are built
from: the problem itself (compared whole, by its pickled form: the box's bounds scale the
variables and bound them, the options shape the graph), the constraint rows its mechanism's
criteria give (code, not the file: a criterion added to a mechanism in this process builds
another NLP), the phase count, IPOPT's options and where its derivatives came from
(``OPTDESIGN_COMPILE`` and the cache folder, :mod:`optdesign.solver.compiled`), and the
thread that solves (two threads never share an NLP). A process forked from this one
inherits what is kept.

A kept NLP carries no state from one solve to the next: each IPOPT run starts from the
values, bounds and parameters it is given, and its iteration watch is armed afresh
(:meth:`~optdesign.solver.nlp._Watch.start`). What a solve would build is what it is given:
the NLP of exactly the hand-over slots it asks for (a solve that once needed more slots
leaves an NLP of more slots here, which a later solve asking for fewer is not given: IPOPT
on it would take another path). So a solve on kept NLPs makes the same iterations, to the
bit, as on new ones. At most :data:`KEPT` problems' counts are kept, holding at most
:data:`KEPT_BYTES` together (more only where the one asked for holds more alone), the least
recently used let go first.
"""
from __future__ import annotations

import hashlib
import os
import pickle
import threading
from collections import OrderedDict

from optdesign.solver import compiled

#: phase counts' NLPs kept (problems × counts)
KEPT = 16
#: ... and the C heap's bytes they may hold together (``PhaseNLP.held_bytes``). The disc
#: problem's NLP at 24 phases holds 29 MB with IPOPT on L-BFGS (111 MB with the exact Hessian
#: built too), so sixteen of the race's fit; a four-bar's at 24 phases with bounds on its swing
#: and ripple holds 344 MB (1.27 GB), and sixteen such (a notebook that changes a bound: each
#: bound a problem of its own) would hold 20 GB. The least recently used are let go first, the
#: one asked for never.
KEPT_BYTES = 2 * 2**30

_kept: OrderedDict = OrderedDict()
_lock = threading.Lock()


def key_of(problem, count: int) -> bytes:
    """What an NLP of ``problem``'s ``count`` is built from, as bytes (equal problems give
    equal keys, in this process or in a forked one that received a pickled copy)."""
    from optdesign.quantities.criteria import constraints_of
    from optdesign.solver.nlp import IPOPT_OPTIONS

    cache = os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~")
    # the rows the mechanism's criteria give (code, not the file: a criterion added to a
    # mechanism in this process builds another NLP)
    rows = [(type(c).__qualname__, c.name) for c in constraints_of(problem)]
    # Pickle writes an object met twice once (by reference) and interns the attribute names
    # it reads back, so equal problems may pickle to different bytes: a copy a worker
    # received shares other strings than the problem it was made from. Each part is pickled
    # on its own, and the problem as its copy is (read back once): the same bytes for both.
    # The thread is a part: an NLP's IPOPT function and its iteration watch serve one run at
    # a time (a process forked from a thread runs on a copy of it, and inherits its NLPs).
    parts = (compiled.mode(), cache, sorted(IPOPT_OPTIONS.items()), rows,
             pickle.loads(pickle.dumps(problem)), int(count), threading.get_ident())
    return b"".join(hashlib.sha256(pickle.dumps(part)).digest() for part in parts)


def kept(problem, count: int) -> dict:
    """The NLPs of ``problem``'s ``count`` built in this process, by their number of
    hand-over slots: the same dict on every call, which the caller fills as it builds."""
    key = key_of(problem, count)
    with _lock:
        nlps = _kept.pop(key, None)
        _kept[key] = nlps = {} if nlps is None else nlps
        while len(_kept) > KEPT or len(_kept) > 1 and held_bytes() > KEPT_BYTES:
            _kept.popitem(last=False)
    return nlps


def held() -> frozenset:
    """(key, slots) of every NLP kept in this process (:func:`key_of`): what a process
    forked now holds built."""
    with _lock:
        return frozenset((key, slots) for key, nlps in _kept.items() for slots in nlps)


def held_bytes() -> int:
    """The C heap's bytes the kept NLPs hold (as their builds measured them)."""
    return sum(nlp.held_bytes for nlps in _kept.values() for nlp in nlps.values())


def forget() -> None:
    """Let go of every kept NLP (the next solve of each problem builds it again)."""
    with _lock:
        _kept.clear()

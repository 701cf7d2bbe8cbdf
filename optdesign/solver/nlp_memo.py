"""What an NLP is, kept on disk beside its compiled library: a later process skips its graph.

A phase count's NLP (:class:`~optdesign.solver.nlp.PhaseNLP`) is a CasADi graph of tens of
thousands of nodes, built in Python (0.01 s at 4 phases, 0.03 s at 24) and serialised once
more to name its compiled library (:mod:`optdesign.solver.compiled`: the digest of the
graph). Once the library is there, IPOPT needs nothing of the graph but the library; the
solve needs the NLP's layout (where each variable, row and parameter sits), a few facts
the build learns (the picks, the tracked quantities, the rows of each criterion) and three
small functions of it (the running sums' start values, the surrogate's figures, the picks'
candidates). Those are kept here, as a record named by everything the graph is made from:

* the problem whole (its pickled form, as :func:`optdesign.solver.built.key_of` compares
  problems in one process), the rows its mechanism's criteria give, the count, the hand-over
  slots, IPOPT's options and ``OPTDESIGN_COMPILE``;
* the code: the path, modification time and size of every file of the package;
* what computes the graph's constants: the versions of Python, NumPy and CasADi, the machine,
  the C library and NumPy's CPU features (a cache folder shared by two machines whose sine
  differs in the last bit names two records).

A record is written only for an NLP whose library was found (never one for each NLP a script
of many distinct problems runs through: those have no library), at most
:data:`KEPT_RECORDS` of them for :data:`KEPT_DAYS` each; it is read on the cache folder's
terms (:mod:`optdesign.numerics.user_cache`: the user's own file, closed to others, sealed
with its name and a checksum) and used only where the library it names is intact: else the
graph is built as before. A record read gives the NLP the build would give, to the bit: the
functions as CasADi serialised them, the layout as the build laid it out
(``tests/solve/test_nlp_memo.py`` compares both, and the answers with and without records).
"""
from __future__ import annotations

import hashlib
import pickle

from optdesign.numerics import code_stamp, user_cache

#: the record's layout: part of its name
FORMAT = 1
#: the records' trailer tag (:mod:`optdesign.numerics.user_cache`)
TAG = "optdesign-nlp-record"
#: what the graph's code and constants come from besides the problem (the package's files,
#: the versions, the machine: :func:`optdesign.numerics.code_stamp.environment`)
_environment = code_stamp.environment


def key_of(problem, count: int, slots: int, criteria, ipopt_options: dict) -> str | None:
    """The name of the record of ``problem``'s NLP of ``count`` with ``slots`` hand-over
    slots, its ``criteria`` (the constraints whose rows it holds) and ``ipopt_options`` (a
    sha256 digest), or None where nothing is cached (``OPTDESIGN_COMPILE=off``)."""
    how = user_cache.mode()
    if how == "off":
        return None
    rows = [(type(c).__module__, type(c).__qualname__, c.name) for c in criteria]
    digest = hashlib.sha256()
    for part in (FORMAT, _environment(), how, sorted(ipopt_options.items()), rows,
                 pickle.loads(pickle.dumps(problem)), int(count), int(slots)):
        digest.update(hashlib.sha256(pickle.dumps(part)).digest())
    return digest.hexdigest()


def read(key: str | None) -> dict | None:
    """The record named ``key``, or None: no folder in use, none kept, or one not to be
    trusted or not to be read."""
    return None if key is None else user_cache.read_record(_name(key), TAG, key, FORMAT)


def write(key: str | None, record: dict) -> None:
    """Keep ``record`` as ``key``'s (atomically; a failure costs the next process its graph),
    and let go of the records written more than :data:`KEPT_DAYS` ago."""
    if key is None:
        return
    where = user_cache.write_record(_name(key), TAG, key, FORMAT, record)
    if where is not None:
        user_cache.let_go_of_old(where, "nlp-record-", ".json", KEPT_DAYS, KEPT_RECORDS)


#: a record is named by the package's files too, so every change of the code names new ones:
#: one written this many days ago is removed when another is written (one still in use is
#: written again by the next solve that finds its library, at the cost of one graph)
KEPT_DAYS = 30
#: ... and at most this many are kept, the oldest let go first: a record is named by the whole
#: problem, so a script that solves one problem under many bounds (its NLP's graph and library
#: the same) writes one for each (0.1 to 0.4 MB each for the race's problems)
KEPT_RECORDS = 128


def _name(key: str) -> str:
    return f"nlp-record-{key[:40]}.json"

"""Where a command's wall time goes: its phases, written down only when asked for.

A command wraps its steps in ``with phase("reading"):`` and calls :func:`answered` the moment
its answer is out (printed, or its result file written). Nothing is recorded, and nothing
changes, unless the environment variable ``OPTDESIGN_PHASES`` names a file: then the process
appends one JSON line to that file as it exits::

    {"argv": ["solve", "p.yaml"], "pid": 4242, "started": 1764000000.123456,
     "phases": [["imports", 0.004, 0.081], ["reading", 0.081, 0.093], ...],
     "answer_s": 1.91, "exit_s": 2.85}

``started`` is the wall clock (``time.time()``) when this module was imported, which the
command line (:mod:`optdesign.cli`) does first; every other time is in seconds after it, read on
``time.perf_counter()``. A caller that reads ``time.time()`` just before it starts the process
learns the interpreter's own start-up as well (``benchmarks/command_latency.py``). The phases
of a command follow one another: a phase opened inside another is part of the outer one and
is not recorded (``solve``'s figures include the animation page, a phase of its own in
``animate``); one name may come back (its times add up).
The names the commands use: ``imports``, ``reading``, ``solving``, ``evaluating``, ``files``
and ``figures``.

The line is one ``write`` with ``O_APPEND``: the lines of processes that end at once never
interleave, and a reader sees whole lines only. A child process forked by the command (a
solver's worker, the figures' process) writes nothing. Writing the line never changes the
command's outcome: a file that cannot be written is left without the line.
"""
from __future__ import annotations

import os
import time
from contextlib import contextmanager

#: the environment variable naming the file the phases are appended to
VARIABLE = "OPTDESIGN_PHASES"

_STARTED = time.time()
_T0 = time.perf_counter()
_PID = os.getpid()
_phases: list[list] = []
_open: list[str] = []            # the phase running now, if any
_answer: list[float] = []
_registered: list[bool] = []


def restart(started: float) -> None:
    """Count from ``started`` (the wall clock) again, with nothing recorded: the warm
    server's child runs a command that started in its client (:mod:`optdesign.warm`)."""
    global _STARTED, _T0, _PID
    _STARTED = started
    _T0 = time.perf_counter() - (time.time() - started)
    _PID = os.getpid()
    for done in (_phases, _open, _answer):
        done.clear()
    _wanted()


def handed_over() -> None:
    """The command ran in another process, which writes its line: this one writes none."""
    global _PID
    _PID = -1


def started() -> float:
    """The program's start on the wall clock."""
    return _STARTED


def _now() -> float:
    return time.perf_counter() - _T0


def _wanted() -> bool:
    """True when the phases are to be written; the first call registers the writer."""
    if not os.environ.get(VARIABLE):
        return False
    if not _registered:
        import atexit
        atexit.register(_write)
        _registered.append(True)
    return True


@contextmanager
def phase(name: str):
    """Time the block as the phase ``name`` (a no-op unless ``OPTDESIGN_PHASES`` is set)."""
    if not _wanted() or _open:
        yield
        return
    start = _now()
    _open.append(name)
    try:
        yield
    finally:
        _open.clear()
        _phases.append([name, round(start, 6), round(_now(), 6)])


def answered() -> None:
    """The command's answer is out: printed, or its result file written (the first call
    counts)."""
    if _wanted() and not _answer:
        _answer.append(_now())


def record() -> dict:
    """The line this process writes at exit, as it stands now."""
    import sys

    return {"argv": sys.argv[1:], "pid": os.getpid(), "started": round(_STARTED, 6),
            "phases": [list(p) for p in _phases],
            "answer_s": round(_answer[0], 6) if _answer else None,
            "exit_s": round(_now(), 6)}


def _write() -> None:
    path = os.environ.get(VARIABLE)
    if not path or os.getpid() != _PID:          # a forked child ends without a word
        return
    import json

    line = json.dumps(record(), separators=(",", ":")) + "\n"
    try:
        fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_CLOEXEC, 0o644)
    except OSError:
        return
    try:
        os.write(fd, line.encode("utf-8"))       # one write: the line whole or not at all
    except OSError:
        pass
    finally:
        os.close(fd)


_wanted()           # set when the program starts: the line is written even if no phase runs

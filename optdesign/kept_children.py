"""Children forked once and kept: a value asked beside this process again and again (a solve's
best basins, polished at once, solve after solve in a notebook or a warm benchmark) is
computed by a child that holds what it needs already, instead of by a child forked for it.

:func:`optdesign.lifetime.beside` forks a child for each value. The fork itself costs a few
milliseconds, and then both processes pay for every page of memory they shared as they first
write it: an IPOPT run in the parent right after a fork copies a thousand pages or more (its
arrays, and the Python objects it touches; ``benchmarks/fork_cost.py`` times it alone and
after a fork), and the child's likewise. A kept child pays that once, as it is forked.

A value is asked of a kept child with what it needs named (:func:`beside`'s ``needs``: the
NLPs the polish runs on): an idle kept child that holds all of it computes the value, the
function and its arguments sent to it pickled; else a child is forked now, which inherits
this process's memory (it holds what this process holds: ``inherits``) and is kept for
later, at most :func:`most_kept` of them (an idle one that holds less is let go for it).
A child holds what it inherited and what it was asked with since. The value is the one this
process would compute (the function a pure one of its arguments and of what each process
builds the same way), as from a child forked for it: only the time differs.

A kept child serves the thread it was forked for (an NLP is its thread's:
:mod:`optdesign.solver.built`). It dies with this process
(:func:`optdesign.lifetime.die_with_parent`, and daemonic: a process of multiprocessing's own
that exits ends it), as its pipe closes, when its thread has ended, and when its value is no
longer wanted (:meth:`Kept.cancel`: a child left computing would hold the next value up).
Where the platform cannot fork, the value is :func:`optdesign.lifetime.beside`'s (computed
here).
"""
from __future__ import annotations

import atexit
import multiprocessing.util  # noqa: F401 - its exit handler registered before ours
import os
import threading

from optdesign import lifetime


def most_kept() -> int:
    """The kept children at most: one per core beside this process's."""
    from optdesign.limits import cores

    return max(1, cores() - 1)


class _Child:
    """A kept child: its process, its two pipe ends, what it holds, whether it computes."""

    def __init__(self, process, requests, answers, holds: frozenset):
        self.process, self.requests, self.answers = process, requests, answers
        self.holds = set(holds)
        self.busy = False
        self.thread = threading.get_ident()

    def end(self) -> None:
        """Kill the child and close its pipes (it computes nothing more)."""
        try:
            self.process.kill()
            self.process.join()
        except (OSError, ValueError, AssertionError):
            pass
        self.close_pipes()

    def close_pipes(self) -> None:
        """Close this process's ends of the child's pipes."""
        for end in (self.requests, self.answers):
            try:
                end.close()
            except OSError:
                pass


_children: list[_Child] = []
#: re-entrant: a value never asked for ends its child as it is collected
#: (:meth:`Kept.__del__`), which may happen inside this module's own locked blocks
_lock = threading.RLock()


def beside(fn, *args, needs=frozenset(), inherits=frozenset, fork: bool = True,
           gains=frozenset()):
    """``fn(*args)`` computed in a kept child (see the module's text) and a :class:`Kept`
    that waits for its value when called: an idle child of this thread that holds
    ``needs`` (a set of hashable names), else one forked now, which holds ``inherits()``
    (what this process holds as it forks) and ``needs`` afterwards. Either holds ``gains``
    too once it has computed the value (what computing it builds, that a later value may
    need: :func:`optdesign.solver.polishing.answer_record_beside`). Where no child can be
    kept (the cap reached, every child busy; no ``fork``), :func:`optdesign.lifetime.beside`'s
    child computes it. Without ``fork``: None where no idle child holds ``needs`` (the
    caller computes the value itself)."""
    needs = frozenset(needs)
    me = threading.get_ident()
    with _lock:
        threads = {t.ident for t in threading.enumerate()}
        for gone in [c for c in _children if not c.busy and (
                not c.process.is_alive() or c.thread not in threads)]:
            _children.remove(gone)          # died idle (killed from outside), or its thread
            gone.end()                      # ended (an NLP is its thread's: none to reuse)
        mine = [c for c in _children if not c.busy and c.thread == me]
        child = next((c for c in mine if needs <= c.holds), None)
        if child is None and not fork:
            return None
        if child is None:
            if len(_children) >= most_kept() and not mine:
                return lifetime.beside(fn, *args)
            if len(_children) >= most_kept():   # holds less: let go for one that holds it
                _children.remove(mine[0])
                mine[0].end()
        else:
            child.busy = True
    if child is None:
        child = _forked(frozenset(inherits()))      # (outside the lock: not the child's)
        if child is None:
            return lifetime.beside(fn, *args)
        child.busy = True
        with _lock:
            _children.append(child)
    try:
        child.requests.send((fn, args))
    except Exception:                   # noqa: BLE001 - lost, or arguments that do not pickle
        _let_go(child)
        return lifetime.beside(fn, *args) if fork else None
    return Kept(fn, args, child, needs | frozenset(gains))


def pids() -> frozenset:
    """The process ids of the children kept now (a benchmark waits for every other child)."""
    with _lock:
        return frozenset(c.process.pid for c in _children)


def end_all() -> None:
    """Let every kept child go (a new problem's NLPs will not be theirs; tests)."""
    with _lock:
        children, _children[:] = list(_children), []
    for child in children:
        child.end()


def _forked(holds: frozenset) -> _Child | None:
    import multiprocessing as mp

    try:
        ctx = mp.get_context("fork")
        requests_in, requests_out = ctx.Pipe(duplex=False)
        answers_in, answers_out = ctx.Pipe(duplex=False)
        # daemonic: a process of multiprocessing's own that exits ends it, where it would
        # wait for a child of another kind to end (which waits for its next value)
        process = ctx.Process(target=_serve, daemon=True,
                              args=(requests_in, requests_out, answers_in, answers_out,
                                    os.getpid()))
        with lifetime.signals_held():
            process.start()
    except (ValueError, OSError, AssertionError):  # no fork here, or a daemon's child
        return None
    requests_in.close()
    answers_out.close()
    return _Child(process, requests_out, answers_in, holds)


def _serve(requests_in, requests_out, answers_in, answers_out, parent_pid: int) -> None:
    """The kept child's loop: each value asked, computed and sent back, until the pipe
    closes."""
    requests_out.close()
    answers_in.close()
    lifetime.die_with_parent(parent_pid)
    while True:
        try:
            fn, args = requests_in.recv()
        except (EOFError, OSError):
            os._exit(0)
        try:
            answer = ("value", fn(*args))
        except BaseException as error:      # noqa: BLE001 - handed to the parent as it is
            answer = ("error", error)
        try:
            answers_out.send(answer)
        except (OSError, ValueError):
            os._exit(0)
        except Exception as exc:            # an answer that does not pickle
            answers_out.send(("error", RuntimeError(f"no value from a kept child: {exc}")))


def _reset_in_child() -> None:
    """A forked process keeps none of its parent's children (nor its lock's state)."""
    global _lock
    _lock = threading.RLock()
    for child in _children:         # their pipes' ends, inherited: closed here alone
        child.close_pipes()
    _children.clear()


os.register_at_fork(after_in_child=_reset_in_child)
# before multiprocessing's own exit handler (registered earlier, so run later), which would
# wait for a kept child to end: ended here
atexit.register(end_all)


def _let_go(child: _Child) -> None:
    with _lock:
        if child in _children:
            _children.remove(child)
    child.end()


class Kept:
    """A value computed by a kept child (:func:`beside`): called, it waits for it
    (:meth:`ready` tells whether it would) and the child is free again; if the child is
    lost, the value is computed here. :meth:`cancel` ends the child where the value is no
    longer wanted. The same calls as :class:`optdesign.lifetime.Beside`."""

    def __init__(self, fn, args, child: _Child, holds: frozenset):
        #: what the child holds once it has computed the value (:func:`beside`'s ``needs``
        #: and ``gains``)
        self.fn, self.args, self.child, self.holds = fn, args, child, holds

    def __call__(self):
        child = self.child
        if child is None:
            return self.fn(*self.args)
        kind, value = lifetime.received(child.answers, self.cancel)
        self.child = None
        if kind == "lost":
            _let_go(child)
            return self.fn(*self.args)
        with _lock:
            child.holds |= self.holds
            child.busy = False
        if kind == "error":
            raise value
        return value

    def ready(self) -> bool:
        return self.child is None or lifetime.arrived(self.child.answers)

    def cancel(self) -> None:
        """End the child (it may be computing still) and forget the value."""
        if self.child is not None:
            _let_go(self.child)
            self.child = None
        self.fn = lifetime.cancelled

    def __del__(self):
        if getattr(self, "child", None) is not None:    # never asked: the child computes on
            try:
                self.cancel()
            except Exception:               # noqa: BLE001 - at interpreter exit
                pass


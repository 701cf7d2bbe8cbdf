"""Children forked once and kept (optdesign.kept_children): a value asked with what a child
holds is computed by that child, without a fork; one asked with more is computed by a child
forked for it, which holds what this process held; an error, a lost child, a cancelled value
and the process's exit behave as with a child forked for each value."""
import multiprocessing
import os
import signal
import subprocess
import sys
import time

import pytest

from optdesign import kept_children
from optdesign.evaluation import figures
from tests.test_lifetime import _dies_in_a_child, _fails, _square


def _memory_after(generation):
    """The kept child's memory of evaluations after following ``generation``."""
    figures.follow(generation)
    return len(figures._EVALUATED), figures.generation()


def test_a_value_asked_with_what_a_child_holds_is_computed_by_it_without_a_fork():
    first, child = kept_children.beside(_square, 3, needs={"a"})()
    again, same = kept_children.beside(_square, 4, needs={"a"})()
    inherited, also = kept_children.beside(_square, 5, needs={"b"}, inherits=lambda: {"b"})()
    assert (first, again, inherited) == (9, 16, 25)
    assert child != os.getpid() and same == child
    # "b": not held by the first child, but by one forked now (it inherits what this
    # process holds); with one core beside this process's, the first is let go for it
    assert also != child
    if kept_children.most_kept() == 1:
        assert [c.pid for c in multiprocessing.active_children()] == [also]


def test_a_value_asked_with_more_than_any_child_holds_is_computed_by_a_new_child():
    _, child = kept_children.beside(_square, 3, needs={"a"})()
    _, other = kept_children.beside(_square, 3, needs={"a", "c"})()
    _, third = kept_children.beside(_square, 3, needs={"a", "c"})()
    assert other != child and third == other      # the new child holds "a" and "c" since


def test_what_a_value_builds_is_held_by_its_child_afterwards():
    """``gains``: not asked of a child beforehand, held by the one that computed the value,
    so a later value that needs it is asked of that child alone."""
    assert kept_children.beside(_square, 2, needs={"a", "made"}, fork=False) is None
    _, child = kept_children.beside(_square, 3, needs={"a"}, gains={"made"})()
    _, same = kept_children.beside(_square, 4, needs={"a", "made"}, fork=False)()
    assert same == child != os.getpid()
    assert kept_children.beside(_square, 2, needs={"a", "other"}, fork=False) is None


def test_the_childs_error_is_raised_here_and_the_child_serves_on():
    with pytest.raises(ValueError, match="no square of 3"):
        kept_children.beside(_fails, 3)()
    _, child = kept_children.beside(_square, 2)()
    _, same = kept_children.beside(_square, 2)()
    assert same == child != os.getpid()


def test_a_lost_child_is_computed_here_and_let_go():
    assert kept_children.beside(_dies_in_a_child, os.getpid())() == "computed here"
    _, child = kept_children.beside(_square, 2)()
    assert child != os.getpid() and multiprocessing.active_children()[0].pid == child


def test_a_cancelled_value_ends_its_child():
    pending = kept_children.beside(time.sleep, 60)
    assert not pending.ready()
    t0 = time.perf_counter()
    pending.cancel()
    assert time.perf_counter() - t0 < 5 and multiprocessing.active_children() == []
    with pytest.raises(RuntimeError, match="after its child ended"):
        pending()


def test_two_values_at_once_are_two_childrens_or_one_forked_for_it():
    first = kept_children.beside(_square, 2)
    second = kept_children.beside(_square, 3)       # the kept one is busy
    (a, pa), (b, pb) = first(), second()
    assert (a, b) == (4, 9) and os.getpid() not in (pa, pb) and pa != pb


def test_a_child_empties_its_memory_of_evaluations_where_this_process_emptied_its_own():
    from optdesign.evaluation.design import Design
    from tests.conftest import PAPER

    figures.evaluate(Design("fourbar_converter", dict(PAPER)), "forward", 97.0, (1.0,))
    held, generation = kept_children.beside(_memory_after, figures.generation())()
    assert held > 0 and generation == figures.generation()      # inherited, kept
    figures.forget()
    held, generation = kept_children.beside(_memory_after, figures.generation())()
    assert held == 0 and generation == figures.generation()


def test_a_process_with_a_kept_child_exits_at_once_and_leaves_none(tmp_path):
    script = ("import os, sys\nfrom optdesign import kept_children\n"
              "print(kept_children.beside(os.getpid)())\n")
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          timeout=60, cwd=os.path.dirname(os.path.dirname(__file__)))
    assert done.returncode == 0 and time.perf_counter() - t0 < 30
    child = int(done.stdout)
    for _ in range(100):
        if not os.path.exists(f"/proc/{child}") or _zombie(child):
            break
        time.sleep(0.05)
    assert not os.path.exists(f"/proc/{child}") or _zombie(child)


def _zombie(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().split(")")[-1].split()[0] == "Z"
    except OSError:
        return True


def test_without_fork_a_value_is_asked_only_of_an_idle_child_that_holds_what_it_needs():
    assert kept_children.beside(_square, 2, needs={"x"}, fork=False) is None
    _, child = kept_children.beside(_square, 2, needs={"x"})()
    pending = kept_children.beside(_square, 3, needs={"x"}, fork=False)
    assert pending is not None and pending() == (9, child)
    busy = kept_children.beside(time.sleep, 0.2, needs={"x"})
    assert kept_children.beside(_square, 3, needs={"x"}, fork=False) is None   # busy
    busy()
    assert kept_children.beside(_square, 3, needs={"y"}, fork=False) is None


def test_a_kept_child_killed_while_idle_is_let_go_and_another_serves():
    _, child = kept_children.beside(_square, 2)()
    os.kill(child, signal.SIGKILL)
    for _ in range(200):
        if _zombie(child) or not os.path.exists(f"/proc/{child}"):
            break
        time.sleep(0.01)
    value, other = kept_children.beside(_square, 5)()
    assert value == 25 and other not in (child, os.getpid())
    assert [c.pid for c in multiprocessing.active_children()] == [other]


def _keeps_a_child_and_returns(out):
    out.send(kept_children.beside(_square, 3)())


def test_a_multiprocessing_child_with_a_kept_child_of_its_own_exits_at_once():
    """multiprocessing waits, as one of its processes exits, for its children that are not
    daemonic: a kept child (which waits for its next value) is daemonic, ended there."""
    ctx = multiprocessing.get_context("fork")
    receive, send = ctx.Pipe(duplex=False)
    process = ctx.Process(target=_keeps_a_child_and_returns, args=(send,))
    process.start()
    (value, grandchild) = receive.recv()
    process.join(30)
    assert value == 9 and grandchild != process.pid and process.exitcode == 0


def test_the_idle_child_of_a_thread_that_ended_is_let_go_for_another_threads():
    """A kept child serves the thread it was forked for (an NLP is its thread's); once that
    thread has ended, its idle child is let go and another thread's value gets a child kept
    for it, not one forked for the value alone."""
    import threading

    got = []
    worker = threading.Thread(target=lambda: got.append(kept_children.beside(_square, 2)()))
    worker.start()
    worker.join()
    _, first = got[0]
    _, here = kept_children.beside(_square, 3)()
    _, again = kept_children.beside(_square, 4)()
    assert here != first and again == here
    assert [c.pid for c in multiprocessing.active_children()] == [here]

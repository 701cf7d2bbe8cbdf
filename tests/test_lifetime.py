"""A computation beside this process (optdesign.lifetime.beside): its value, its error, and a
child lost without a word; and no Ctrl-C lost, whether it lands as a child is forked, in a
finaliser or inside CasADi's IPOPT."""
import os
import signal
import sys

import pytest

from optdesign.lifetime import beside


def _square(x):
    return x * x, os.getpid()


def _fails(x):
    raise ValueError(f"no square of {x}")


def _dies_in_a_child(parent: int):
    if os.getpid() != parent:
        os.kill(os.getpid(), signal.SIGKILL)
    return "computed here"


def test_the_value_comes_from_a_child():
    value, pid = beside(_square, 7)()
    assert value == 49 and pid != os.getpid()


def test_the_childs_error_is_raised_here():
    with pytest.raises(ValueError, match="no square of 3"):
        beside(_fails, 3)()


def test_a_lost_child_is_computed_here():
    assert beside(_dies_in_a_child, os.getpid())() == "computed here"


def test_ready_tells_whether_the_value_would_be_waited_for():
    import time

    def waited(pending) -> float:
        t0 = time.perf_counter()
        while not pending.ready():
            assert time.perf_counter() - t0 < 30
            time.sleep(0.01)
        return time.perf_counter() - t0

    pending = beside(time.sleep, 0.5)
    assert not pending.ready()              # the child sleeps
    assert waited(pending) > 0.2 and pending() is None
    lost = beside(_dies_in_a_child, os.getpid())
    waited(lost)                            # ready once it ended without a word
    assert lost() == "computed here"


def test_a_cancelled_child_ends_and_its_value_is_not_asked_for():
    import multiprocessing
    import time

    pending = beside(time.sleep, 60)
    t0 = time.perf_counter()
    pending.cancel()
    assert time.perf_counter() - t0 < 5 and multiprocessing.active_children() == []
    with pytest.raises(RuntimeError, match="after its child ended"):
        pending()


# --------------------------------------------------------------------------- no Ctrl-C lost
def _ctrl_c_now():
    """Send this process a SIGINT and give its handler the chance to run."""
    os.kill(os.getpid(), signal.SIGINT)
    for _ in range(100):                    # the handler runs between two bytecodes
        pass


def test_a_ctrl_c_while_signals_are_held_is_raised_as_the_block_ends():
    from optdesign.lifetime import signals_held

    reached = []
    with pytest.raises(KeyboardInterrupt):
        with signals_held():
            _ctrl_c_now()
            reached.append("the end of the block")
    assert reached == ["the end of the block"]


def test_a_child_forked_with_signals_held_sets_its_own():
    """beside forks inside signals_held; the child (die_with_parent) ignores Ctrl-C and ends
    at a SIGTERM, not the parent's recorders of them."""
    assert beside(signal.getsignal, signal.SIGINT)() == signal.SIG_IGN
    assert beside(signal.getsignal, signal.SIGTERM)() == signal.SIG_DFL


def test_casadi_swallows_a_ctrl_c_during_ipopt_and_interrupts_kept_raises_it_again(request,
                                                                                  capsys):
    import threading

    import casadi as ca

    from optdesign.lifetime import interrupts_kept

    x = ca.MX.sym("x", 300)
    # a run that only a Ctrl-C ends (or, should none arrive, a minute of CPU: the test then
    # fails instead of hanging the suite)
    solver = ca.nlpsol("s", "ipopt", {"x": x, "f": ca.sumsqr(ca.sin(x) - ca.cos(ca.cumsum(x)))},
                       {"ipopt.print_level": 0, "print_time": 0, "ipopt.max_iter": 100000,
                        "ipopt.tol": 1e-300, "ipopt.acceptable_iter": 0,
                        "ipopt.max_cpu_time": 60.0})
    # Python's own Ctrl-C handler, whatever an earlier test of this worker left behind
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    request.addfinalizer(lambda: signal.signal(signal.SIGINT, previous))

    def interrupted_run():
        timer = threading.Timer(0.2, os.kill, (os.getpid(), signal.SIGINT))
        timer.start()
        try:
            solver(x0=1.0)
        finally:
            timer.join()
        return solver.stats()["return_status"]

    assert interrupted_run() == "NonIpopt_Exception_Thrown"     # the Ctrl-C is gone
    assert "KeyboardInterruptException" in capsys.readouterr().err   # CasADi's warning
    with pytest.raises(KeyboardInterrupt):
        with interrupts_kept():
            print("a line of its own", file=sys.stderr)
            interrupted_run()
    assert capsys.readouterr().err == "a line of its own\n"         # the warning alone gone


def test_a_ctrl_c_dropped_in_a_finaliser_comes_back_unprinted(capsys):
    from optdesign.lifetime import exit_on_sigterm, raise_if_terminated

    class Finalised:
        def __del__(self):
            _ctrl_c_now()                   # its KeyboardInterrupt is dropped by Python

    reached = []
    with pytest.raises(KeyboardInterrupt):
        with exit_on_sigterm():
            Finalised()                     # made and dropped: the finaliser runs here
            reached.append("past the finaliser")
            raise_if_terminated()
    assert reached == ["past the finaliser"]
    assert "Exception ignored" not in capsys.readouterr().err
    raise_if_terminated()                   # nothing left for a later block of the process


def test_a_sigterm_the_caller_ignores_stays_ignored():
    from optdesign.lifetime import exit_on_sigterm

    kept = signal.signal(signal.SIGTERM, signal.SIG_IGN)
    try:
        with exit_on_sigterm():
            assert signal.getsignal(signal.SIGTERM) == signal.SIG_IGN
            os.kill(os.getpid(), signal.SIGTERM)        # nothing happens
        assert signal.getsignal(signal.SIGTERM) == signal.SIG_IGN
    finally:
        signal.signal(signal.SIGTERM, kept)


def _large_after(seconds: float):
    import time

    time.sleep(seconds)
    return b"x" * (1 << 20)             # more than a pipe holds: the child blocks sending it


def test_a_ctrl_c_while_waiting_ends_the_child():
    """Interrupted while it waits for the value, the parent ends the child and raises: the
    child, with more to send than the pipe holds, is not left blocked on it (nor the parent
    waiting for it to end)."""
    import multiprocessing
    import threading
    import time

    pending = beside(_large_after, 0.5)
    threading.Timer(0.2, lambda: os.kill(os.getpid(), signal.SIGINT)).start()
    t0 = time.perf_counter()
    with pytest.raises(KeyboardInterrupt):
        pending()
    assert time.perf_counter() - t0 < 5 and multiprocessing.active_children() == []

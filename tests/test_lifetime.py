"""A computation beside this process (optdesign.lifetime.beside): its value, its error, and a
child lost without a word."""
import os
import signal

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

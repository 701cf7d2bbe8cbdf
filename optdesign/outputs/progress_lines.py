"""Progress off a terminal: a long command's log says where it is.

On a terminal a command's progress is tqdm's bar on stderr; off one (a log file, a pipe, CI)
the bar is silent. A long ``solve`` then writes a line per phase count once it has run
:data:`AFTER_S` (``solve   31.2 s: 6 of 63 phase counts``), as ``pareto`` writes a line per
stage: a short solve writes none, so a script's stderr holds its one line of error alone.
"""
from __future__ import annotations

import sys
import time

#: a solve that has run this long says, off a terminal, each count it finishes
AFTER_S = 10.0


def is_terminal(stream) -> bool:
    """Whether ``stream`` is a terminal (False for a stream without a file)."""
    try:
        return stream.isatty()
    except (AttributeError, ValueError):
        return False


class CountLines:
    """A solve's progress: ``bar.update`` for each count finished, and off a terminal a line on ``stream`` per
    count once the work has run :data:`AFTER_S`."""

    def __init__(self, bar, total: int, stream=None, after_s: float = AFTER_S):
        self.bar, self.total = bar, total
        self.stream = sys.stderr if stream is None else stream
        self.lines = not is_terminal(self.stream)
        self.after_s, self.t0, self.done = after_s, time.perf_counter(), 0

    def __call__(self) -> None:
        self.done += 1
        self.bar.update()
        elapsed = time.perf_counter() - self.t0
        if self.lines and elapsed >= self.after_s:
            print(f"solve {elapsed:7.1f} s: {self.done} of {self.total} phase counts",
                  file=self.stream, flush=True)

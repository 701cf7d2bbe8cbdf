"""The answer printed the moment it is known, before the figures are drawn.

A command that draws figures prints its result first (:func:`print_answer`: printed, flushed,
and the phase clock's answer marked), then draws. A stdout that cannot take the answer (a
closed pipe, a full disk) must not cost the user the files written after it: the error is
kept, and :func:`raise_if_unprinted` raises it once the files are in place, so the command
line reports it as it did when the answer was printed last (a closed pipe quietly, anything
else in one line; exit 1).
"""
from __future__ import annotations

from optdesign.outputs.phases import answered

_unprinted: list[BaseException] = []


def print_answer(*lines: str) -> None:
    """Print ``lines`` at once; an error of stdout is kept for :func:`raise_if_unprinted`."""
    try:
        for line in lines:
            print(line)
        import sys
        sys.stdout.flush()
    except (OSError, ValueError) as exc:
        _unprinted.append(exc)
    answered()


def raise_if_unprinted() -> None:
    """Raise the first error :func:`print_answer` met since the last call, if any."""
    if _unprinted:
        exc = _unprinted[0]
        _unprinted.clear()
        raise exc

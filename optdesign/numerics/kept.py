"""A memory of the last few results: a dict that lets its oldest entry go when full.

The exact evaluator remembers the designs it checked last, and the turn quantities their
maxima (a solve checks a design again as the next polish's start, or as its answer): each
keeps at most a fixed number of entries, the oldest let go first.
"""
from __future__ import annotations


def keep(memory: dict, size: int, key, value):
    """``value`` into ``memory`` under ``key``, the oldest entries let go so that it holds
    at most ``size``; returns ``value``."""
    if key not in memory:
        while len(memory) >= size:
            memory.pop(next(iter(memory)))
    memory[key] = value
    return value

"""Standard streams that never fail a command: a result is not lost to how it is printed.

* A standard stream the caller closed (``optdesign analyze P >&-``, ``2>&-``) is opened on
  ``/dev/null``: what the command prints there goes nowhere, its exit code is the result's,
  and the descriptor is not free for the next file the command opens (which would then take
  the command's printed lines).
* A character the stream's encoding lacks (``PYTHONIOENCODING=ascii``, a Latin-1 terminal)
  is written by an ASCII name: ω as ``omega``, δ as ``delta``, μ as ``mu``, ° as ``deg``,
  ² as ``^2``; anything else as its closest ASCII letters, or ``?``.

Nothing here imports more than the standard library: the program calls :func:`guard` before
anything else.
"""
from __future__ import annotations

import codecs
import os
import sys

#: the error handler of the standard streams (``codecs.register_error``)
HANDLER = "optdesign-ascii-names"

#: signs that have no letters of their own to fall back on
_NAMES = {
    "°": "deg", "²": "^2", "³": "^3", "⁴": "^4", "⁻": "^-", "·": "*", "×": "x", "−": "-",
    "–": "-", "—": "--", "±": "+/-", "∓": "-/+", "≤": "<=", "≥": ">=", "≠": "!=",
    "≈": "~", "→": "->", "←": "<-", "…": "...", "√": "sqrt", "∞": "inf", "∂": "d",
    "Σ": "Sigma", "∫": "int", "′": "'", "″": "''", "µ": "mu", "½": "1/2", "¾": "3/4",
    "¼": "1/4", "‰": "permille", "“": '"', "”": '"', "‘": "'", "’": "'", "\u00a0": " ",
    "\u202f": " ",
}


def ascii_name(char: str) -> str:
    """``char`` in ASCII: its name for a sign or a Greek letter (``omega``, ``Delta``), its
    base letter for an accented one, else ``?``."""
    if char in _NAMES:
        return _NAMES[char]
    import unicodedata

    name = unicodedata.name(char, "")
    for kind, case in (("GREEK SMALL LETTER ", str.lower), ("GREEK CAPITAL LETTER ",
                                                             str.capitalize)):
        if name.startswith(kind):
            return case(name[len(kind):].split()[0])
    if unicodedata.combining(char):             # a dot or bar over the letter before
        return ""
    plain = unicodedata.normalize("NFKD", char).encode("ascii", "ignore").decode("ascii")
    return plain or "?"


def _names(error: UnicodeError):
    if not isinstance(error, UnicodeEncodeError):
        raise error
    text = error.object[error.start:error.end]
    return "".join(ascii_name(c) for c in text), error.end


codecs.register_error(HANDLER, _names)


def guard() -> None:
    """Open each standard descriptor the caller closed on ``/dev/null``, and have stdout and
    stderr write what their encoding lacks by ASCII names (see the module's text)."""
    for fd, name in ((0, "stdin"), (1, "stdout"), (2, "stderr")):
        try:
            os.fstat(fd)
            if getattr(sys, name) is not None:
                continue
        except OSError:
            null = os.open(os.devnull, os.O_RDONLY if fd == 0 else os.O_WRONLY)
            if null != fd:
                os.dup2(null, fd)
                os.close(null)
        stream = open(fd, "r" if fd == 0 else "w", buffering=1 if fd == 2 else -1,
                      encoding="utf-8", errors=HANDLER if fd else "strict", closefd=False)
        setattr(sys, name, stream)
        setattr(sys, f"__{name}__", stream)
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.reconfigure(errors=HANDLER)
        except (AttributeError, ValueError, OSError):   # not a text file of ours (a test's)
            pass

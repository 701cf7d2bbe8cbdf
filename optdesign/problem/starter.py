"""The starting problem file ``optdesign init`` writes: every key, commented, at its default.

Required keys are set (to a design that assembles, with its lengths free over ranges);
every optional key is written commented out at its default, ``# key: value``, so deleting
the ``# `` of a line, or of a whole section, keeps the file valid and changes nothing. A key
without a default value (it means something only when given) is commented twice,
``# # key: example``. Everything comes from :mod:`optdesign.problem.keys`.
"""
from __future__ import annotations

import textwrap

from optdesign.declarations import Key, REQUIRED
from optdesign.mechanisms import get_mechanism, known
from optdesign.problem.keys import flow, problem_keys

COMMENT_COLUMN = 44
WIDTH = 100
HEADER = (
    "Written by `optdesign init`. The required keys are set; every other key is listed, "
    "commented out at its default: delete the '# ' before a key (or before a section and its "
    "keys) to change it. A key commented twice has no default value: the value shown is an "
    "example, for when its comment's condition holds. Lengths in mm, speeds in rad/s, angles "
    "in degrees (the dynamics section in SI). Every key: docs/problem-file.md in the "
    "optdesign sources; `optdesign schema` prints the JSON Schema. Next: `optdesign analyze "
    "FILE` evaluates the design at its fixed and initial values, `optdesign solve FILE` "
    "optimises it.")


class NoStarter(LookupError):
    """No starting design is known for a mechanism."""


def starters() -> tuple[str, ...]:
    """The mechanisms that declare a starting design (``Mechanism.starter``)."""
    return tuple(name for name in known() if get_mechanism(name).starter is not None)


def starter_text(mechanism: str, name: str | None = None) -> str:
    """The commented starting problem file for ``mechanism`` (``name``: the value shown,
    commented, for ``name:``, whose default is the file's stem)."""
    mech = get_mechanism(mechanism)
    start = mech.starter
    if start is None:
        raise NoStarter(f"no starting design is known for mechanism {mechanism!r} (its "
                        f"class declares no starter); known: {', '.join(starters())}")
    lines = _prose(f"optdesign problem file: {mechanism}, after {mech.source}.")
    lines += [""] + _prose(HEADER) + [""]
    for key in problem_keys(mechanism):
        if key.name == "name":
            lines += _line(f"# name: {flow(name or 'NAME')}", _comment(key))
        elif key.name == "mechanism":
            lines += _line(f"mechanism: {mechanism}", " | ".join(known()))
        elif key.name == "input_speed":
            lines += _line(f"input_speed: {flow(start['input_speed'])}", _comment(key))
        elif key.name == "design":
            lines += _design(key, start["design"])
        elif key.kind == "mapping" and not key.keys:
            continue                                  # a mechanism without options
        elif key.kind == "mapping":
            lines += _line(f"# {key.name}:", _comment(key, values=False))
            for sub in key.keys:
                lines += _commented(sub, "#   ")
        elif key.kind == "either":                    # a section that declares nothing
            lines += _line(f"# # {key.name}: {{}}", key.meaning)
        else:
            lines += _line(f"# {key.name}: {flow(key.sample())}", _comment(key))
    return "\n".join(lines) + "\n"


def _design(key: Key, values: dict) -> list[str]:
    lines = _line("design:", "a number fixes a key; {lower, upper, initial} frees a length")
    for sub in key.keys:
        value = values[sub.name]
        if sub.kind == "count":
            n = int(value)
            lower = max(int(sub.lower), n - 2)
            note = (f"{sub.meaning}, {sub.range_text()}; or {{lower: {lower}, upper: {n + 2}}} "
                    f"or {{choices: [{lower}, {n}, {n + 2}]}}")
        else:
            note = f"{sub.unit}; {sub.meaning}"
        lines += _line(f"  {sub.name}: {flow(value)}", note)
    return lines


def _commented(key: Key, prefix: str) -> list[str]:
    """A key of a commented section: once at its default, twice without one."""
    twice = key.default is None
    text = f"{prefix}{'# ' if twice else ''}{key.name}: {flow(key.sample())}"
    return _line(text, _comment(key))


def _comment(key: Key, values: bool = True) -> str:
    """What the value may be (unit, range), what it means, and when it is needed."""
    allowed = ", ".join(p for p in (key.unit if key.unit != "-" else "", key.range_text())
                       if p and key.kind != "text")
    parts = [allowed] if values and allowed else []
    parts.append(key.meaning)
    if values and key.default is REQUIRED and key.name not in ("input_speed",):
        parts.append("required" + (f" {key.condition}" if key.condition else ""))
    elif values and key.default is None and key.default_text:
        parts.append(f"default: {key.default_text}")
    if values and key.condition and key.default is not REQUIRED and \
            key.condition not in key.meaning:
        parts.append(key.condition)
    return "; ".join(parts)


def _line(text: str, comment: str) -> list[str]:
    """``text`` with ``comment`` beside it from COMMENT_COLUMN, wrapped at WIDTH onto comment
    lines aligned under it."""
    column = max(COMMENT_COLUMN, len(text) + 2)
    room = max(WIDTH - column - 2, 30)
    parts = textwrap.wrap(comment, room) or [""]
    out = [f"{text.ljust(column)}# {parts[0]}".rstrip()]
    out += [f"{' ' * column}# {p}" for p in parts[1:]]
    return out


def _prose(text: str) -> list[str]:
    return [f"# {line}" for line in textwrap.wrap(text, WIDTH - 2)]

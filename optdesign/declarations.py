"""Declarations of a problem file's keys: type, default, unit, range and meaning, written once.

A :class:`Key` is read by the loader (:meth:`Key.read` checks a value against it, with the
loader's :class:`~optdesign.problem.loader.Reader` naming the file and key path) and by the generated
reference (:mod:`optdesign.problem.reference`: docs/problem-file.md, ``optdesign schema``,
``optdesign init``), so the documentation cannot say a default or a range that the loader does
not apply. This module knows nothing of any particular key: the tables live beside the code
that reads them (``optdesign/problem/loader.py`` and each section's module).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Iterable

#: The kinds of value a key takes (``Key.kind``):
#: ``number`` (a finite float), ``integer``, ``text``, ``choice`` (one of ``choices``),
#: ``bool``, ``list`` (of ``item``), ``mapping`` (of ``keys``), ``either`` (any one of
#: ``alternatives``), and the design's ``length`` (a number or ``{lower, upper, initial}``)
#: and ``count`` (an integer, ``{lower, upper}`` or ``{choices: [...]}``).
KINDS = ("number", "integer", "text", "choice", "bool", "list", "mapping", "either", "length",
         "count")


class _Required:
    """The default of a key the file must give."""

    def __repr__(self) -> str:
        return "REQUIRED"


REQUIRED: Any = _Required()


@dataclass(frozen=True)
class Key:
    """One key of a problem file.

    ``lower``/``upper`` bound a number, an integer or a count (``open_lower``/``open_upper``
    exclude the bound itself), or a text's length (``upper``). ``default`` is the value the
    loader uses when the key is absent, :data:`REQUIRED` when it must be given, or None when
    its absence means something the value cannot say (``default_text`` then says what).
    ``example`` is a value to show for a required key or one without a default. ``condition``
    marks a key that only holds together with something else ("instead of wall_mm", "with a
    driveline: section"): a starting file shows it commented out twice.
    """

    name: str
    kind: str
    meaning: str
    unit: str = ""
    default: Any = None
    default_text: str = ""
    lower: float | None = None
    upper: float | None = None
    open_lower: bool = False
    open_upper: bool = False
    choices: tuple | Callable[[], Iterable] = ()
    item: "Key | None" = None
    keys: tuple["Key", ...] = ()
    alternatives: tuple["Key", ...] = ()
    min_items: int = 0
    max_items: int | None = None
    example: Any = None
    condition: str = ""
    nullable: bool = False

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"unknown kind {self.kind!r} of key {self.name!r}")

    # ----------------------------------------------------------------- what it allows
    @property
    def required(self) -> bool:
        return self.default is REQUIRED

    def allowed(self) -> tuple:
        """The choices of a ``choice`` key (a callable resolved now: a registry can grow)."""
        return tuple(self.choices() if callable(self.choices) else self.choices)

    def key(self, name: str) -> "Key":
        """The nested key ``name`` of a mapping."""
        return next(k for k in self.keys if k.name == name)

    def read_given(self, reader, raw, wanted) -> tuple[dict, dict]:
        """A section's opening: ``raw`` (None: empty) checked as a mapping of this key's
        known keys, then each of ``wanted`` that it gives read by its declaration. Returns
        (the mapping, ``{"source": reader.where, name: value, ...}``)."""
        raw = reader.mapping({} if raw is None else raw, "")
        reader.known_keys(raw, "", names(self.keys))
        given = {"source": reader.where}
        given.update({name: self.key(name).read(reader, raw[name], name)
                      for name in wanted if name in raw})
        return raw, given

    def sample(self):
        """A value that satisfies the key: its default, else its example."""
        return self.default if self.default not in (None, REQUIRED) else self.example

    def range_text(self) -> str:
        """The allowed values in words: ``[0, 90)``, ``> 0``, ``≥ 16 and ≤ 2000`` ..."""
        lo, hi = self.lower, self.upper
        if self.kind == "choice":
            return " | ".join(str(c) for c in self.allowed())
        if self.kind == "bool":
            return "true | false"
        if self.kind == "text":
            return f"at most {hi:g} characters" if hi is not None else ""
        if self.kind == "list":
            count = (f"{self.min_items} to {self.max_items} items" if self.max_items is not None
                     else f"{self.min_items} or more items" if self.min_items else "any items")
            each = self.item.range_text() if self.item is not None else ""
            return count + (f", each {each}" if each else "")
        if self.kind == "either":
            return " or ".join(t for t in (a.range_text() for a in self.alternatives) if t)
        if lo is not None and lo == hi and not (self.open_lower or self.open_upper):
            return _number(lo, self.kind in ("integer", "count"))
        whole = self.kind in ("integer", "count")
        lo, hi = (_number(v, whole) for v in (lo, hi))
        if lo is not None and hi is not None:
            return f"{'(' if self.open_lower else '['}{lo}, {hi}{')' if self.open_upper else ']'}"
        if lo is not None:
            return f"{'>' if self.open_lower else '≥'} {lo}"
        if hi is not None:
            return f"{'<' if self.open_upper else '≤'} {hi}"
        return ""

    # ----------------------------------------------------------------- reading
    def read(self, reader, value, path: str):
        """``value`` checked against this key: a ProblemError from ``reader`` (naming the
        file and ``path``) when it is of the wrong type or out of range. Numbers, integers,
        texts, choices and booleans only; the other kinds have readers of their own."""
        if self.kind == "number":
            positive = self.lower == 0 and self.open_lower
            number = reader.number(value, path, positive=positive)
            return self._in_range(reader, number, path)
        if self.kind == "integer":
            lo = int(self.lower) if self.lower is not None else 0
            if self.upper is None:
                return reader.integer(value, path, lo)
            return reader.integer(value, path, lo, int(self.upper))
        if self.kind == "bool":
            if not isinstance(value, bool):
                raise reader.error(path, "must be true or false")
            return value
        if self.kind == "text":
            return reader.text(value, path) if self.upper is None else \
                reader.text(value, path, limit=int(self.upper))
        if self.kind == "choice":
            return reader.choice(value, path, self.allowed())
        raise TypeError(f"key {self.name!r} of kind {self.kind} has no generic reader")

    def _in_range(self, reader, number: float, path: str) -> float:
        lo, hi = self.lower, self.upper
        below = lo is not None and (number <= lo if self.open_lower else number < lo)
        above = hi is not None and (number >= hi if self.open_upper else number > hi)
        if not (below or above):
            return number
        unit = f" {self.unit}" if self.unit and self.unit != "-" else ""
        if lo is not None and hi is not None:
            raise reader.error(path, f"must lie in {self.range_text()}{unit} (got {number:g})")
        if below and lo == 0 and not self.open_lower:
            raise reader.error(path, f"must not be negative (got {number:g})")
        if below:
            word = "exceed" if self.open_lower else "be at least"
            raise reader.error(path, f"must {word} {lo:g}{unit} (got {number:g})")
        word = "be below" if self.open_upper else "be at most"
        raise reader.error(path, f"must {word} {hi:g}{unit} (got {number:g})")


def _number(value, whole: bool) -> str | None:
    """A bound as text: an integer's every digit, a float's shortest form."""
    if value is None:
        return None
    return str(int(value)) if whole else f"{value:g}"


def names(keys: Iterable[Key]) -> set[str]:
    """The names of ``keys``: the set a reader's ``known_keys`` accepts."""
    return {k.name for k in keys}

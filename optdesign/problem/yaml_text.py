"""A problem file's YAML, read with limits: nothing in the file can hang, exhaust memory or
overflow the stack before :mod:`optdesign.problem.loader` checks its keys.

The limits (docs/contract.md, "Limits") are checked while PyYAML composes the node graph,
before any Python object is built: the file is a regular file of at most ``MAX_FILE_BYTES``
UTF-8 bytes; mappings and lists nest at most ``MAX_DEPTH`` deep and hold at most
``MAX_NODES`` nodes, both counted with every alias expanded (so nine nested lists of nine
aliases, a few hundred bytes that expand to 9⁹ items, are refused at once); a scalar has at
most ``MAX_SCALAR_CHARS`` characters; a key given twice in one mapping is an error (PyYAML
keeps the last silently); an alias may not refer to a node that contains it.
"""
from __future__ import annotations

import os
import re
import stat
from pathlib import Path

import yaml
from yaml.nodes import MappingNode, ScalarNode, SequenceNode

from optdesign.errors import ProblemError, shown

MAX_FILE_BYTES = 1 << 20        # 1 MiB; the problem files in problems/ are about 1 kB
MAX_DEPTH = 16                  # the deepest key path of the contract is 4 levels
MAX_NODES = 10_000              # scalars, lists and mappings, aliases expanded
MAX_SCALAR_CHARS = 1_000

MERGE_TAG = "tag:yaml.org,2002:merge"


class LimitError(yaml.MarkedYAMLError):
    """The file breaks one of the limits above; ``problem`` says which, the mark where."""


class BoundedLoader(yaml.SafeLoader):
    """PyYAML's safe loader with the module's limits, and ``1e7`` read as a number as YAML 1.2
    does (YAML 1.1 wants ``1.0e+7``; a designer writing stiffness 1e7 means a number)."""

    def __init__(self, stream):
        super().__init__(stream)
        self._depth = 0
        self._extent: dict[int, tuple[int, int]] = {}   # id(node) -> (nodes, height) expanded

    # ------------------------------------------------------------------ composing
    def compose_node(self, parent, index):
        if self.check_event(yaml.AliasEvent):
            event = self.peek_event()
            target = self.anchors.get(event.anchor)
            if target is not None and id(target) not in self._extent:
                raise LimitError(None, None, f"alias *{event.anchor} refers to a node that "
                                             f"contains it", event.start_mark)
            return super().compose_node(parent, index)
        mark = self.peek_event().start_mark
        self._depth += 1
        if self._depth > MAX_DEPTH:
            raise LimitError(None, None, f"nests deeper than {MAX_DEPTH} levels", mark)
        try:
            node = super().compose_node(parent, index)
        finally:
            self._depth -= 1
        self._measure(node, mark)
        return node

    def _measure(self, node, mark) -> None:
        """Nodes and height of ``node`` with every alias expanded, from its children's."""
        if isinstance(node, SequenceNode):
            children = node.value
        elif isinstance(node, MappingNode):
            children = [n for pair in node.value for n in pair]
        else:
            children = []
        extents = [self._extent[id(c)] for c in children]
        nodes = 1 + sum(n for n, _ in extents)
        height = 1 + max((h for _, h in extents), default=0)
        if nodes > MAX_NODES:
            raise LimitError(None, None, f"holds more than {MAX_NODES} values (aliases "
                                         f"expanded)", mark)
        if height > MAX_DEPTH:
            raise LimitError(None, None, f"nests deeper than {MAX_DEPTH} levels (aliases "
                                         f"expanded)", mark)
        self._extent[id(node)] = (nodes, height)

    def compose_scalar_node(self, anchor):
        event = self.peek_event()
        if len(event.value) > MAX_SCALAR_CHARS:
            raise LimitError(None, None, f"has a value longer than {MAX_SCALAR_CHARS} "
                                         f"characters", event.start_mark)
        return super().compose_scalar_node(anchor)

    def compose_mapping_node(self, anchor):
        node = super().compose_mapping_node(anchor)
        seen = set()
        for key, _ in node.value:
            if isinstance(key, ScalarNode) and key.tag != MERGE_TAG:
                if (key.tag, key.value) in seen:
                    raise LimitError(None, None, f"has the key {_short(key.value)} twice in "
                                                 f"one mapping", key.start_mark)
                seen.add((key.tag, key.value))
        return node

    # ------------------------------------------------------------------ constructing
    def construct_object(self, node, deep=False):
        """A scalar PyYAML resolves but cannot build (a date with month 13) is a YAML error
        with its line, not a ValueError from deep inside the constructor."""
        try:
            return super().construct_object(node, deep)
        except (ValueError, OverflowError, TypeError) as exc:
            raise yaml.constructor.ConstructorError(
                None, None, f"cannot read a value ({type(exc).__name__})",
                node.start_mark) from None


BoundedLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"""^[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"""),
    list("-+0123456789"))


def _short(text: str, limit: int = 40) -> str:
    return shown(text, limit)


def read_text(path: Path) -> str:
    """The file's text: a regular file (not a FIFO, a device or a folder, which could block
    or never end), at most ``MAX_FILE_BYTES``, UTF-8."""
    name = str(path)
    # as the message shows it: a newline in a name would break the one-line message
    where = name if name.isprintable() else shown(name, len(repr(name)))
    try:
        fd = os.open(name, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except FileNotFoundError:
        raise ProblemError(f"{where}: no such file") from None
    except OSError as exc:
        raise ProblemError(f"{where}: cannot be read ({exc.strerror or type(exc).__name__})") \
            from None
    except ValueError:                  # a NUL byte in the path
        raise ProblemError(f"{where}: is not a file name") from None
    mode = os.fstat(fd).st_mode
    if not stat.S_ISREG(mode):
        os.close(fd)
        if stat.S_ISDIR(mode):
            raise ProblemError(f"{where}: is a folder, not a problem file")
        raise ProblemError(f"{where}: is not a regular file (a pipe or a device); "
                           f"save it to a file")
    with os.fdopen(fd, "rb") as fh:
        try:
            data = fh.read(MAX_FILE_BYTES + 1)
        except OSError as exc:
            raise ProblemError(f"{where}: cannot be read "
                               f"({exc.strerror or type(exc).__name__})") from None
    if len(data) > MAX_FILE_BYTES:
        raise ProblemError(f"{where}: is larger than {MAX_FILE_BYTES // 1024} KiB; a problem "
                           f"file is a few kB")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ProblemError(f"{where}: is not UTF-8 text (byte {exc.start})") from None


def parse(text: str, where: str):
    """The YAML document in ``text``, with the limits; a ProblemError naming ``where`` and the
    line on any error."""
    loader = None
    try:
        loader = BoundedLoader(text)     # checks that every character is printable
        return loader.get_single_data()
    except LimitError as exc:
        raise ProblemError(f"{where}: {exc.problem} at line {exc.problem_mark.line + 1}") \
            from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        at = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        reason = _one_line(getattr(exc, "problem", None) or "")
        raise ProblemError(f"{where}: not valid YAML{at}" + (f": {reason}" if reason else "")) \
            from None
    except RecursionError:          # pragma: no cover - MAX_DEPTH keeps far below the limit
        raise ProblemError(f"{where}: nests too deep") from None
    finally:
        if loader is not None:
            loader.dispose()


def _one_line(text: str, most: int = 160) -> str:
    """The parser's reason as one printable line of at most ``most`` characters."""
    flat = " ".join("".join(c if c.isprintable() else "?" for c in str(text)).split())
    return flat if len(flat) <= most else flat[:most - 1] + "…"

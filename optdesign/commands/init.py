"""``optdesign init [--mechanism NAME] [--out FILE] [--force]``: a starting problem file."""
from __future__ import annotations

import os
from pathlib import Path


def add_parser(sub) -> None:
    p = sub.add_parser("init", help="write a starting problem file: every key, the optional "
                                    "ones commented out at their defaults")
    p.add_argument("--mechanism", default="fourbar_converter",
                   help="the mechanism (default fourbar_converter; an unknown name lists "
                        "the known ones)")
    p.add_argument("--out", help="the file to write (default: print it)")
    p.add_argument("--force", action="store_true", help="overwrite an existing --out file")
    p.set_defaults(run=run)


def run(args) -> int:
    from optdesign.errors import UsageError, shown
    from optdesign.mechanisms import known
    from optdesign.problem.starter import starter_text, starters

    if args.mechanism not in known():
        raise UsageError(f"--mechanism: unknown mechanism {shown(args.mechanism)}; known: "
                         f"{', '.join(known())}")
    if args.mechanism not in starters():
        raise UsageError(f"--mechanism: no starting design is known for {args.mechanism}")
    if args.out is None:
        print(starter_text(args.mechanism), end="")
        return 0
    path = _checked_out(Path(args.out), args.force)
    from optdesign.outputs.atomic import atomic_write_text

    from optdesign.problem.loader import name_from_stem

    try:
        atomic_write_text(path, starter_text(args.mechanism, name=name_from_stem(path.stem)))
    except OSError as exc:        # a read-only or kernel folder: name --out, not a temporary
        raise UsageError(f"--out {shown(str(path))}: cannot write there "
                         f"({exc.strerror or type(exc).__name__})") from None
    print(f"wrote {path}")
    return 0


def _checked_out(path: Path, force: bool) -> Path:
    """``path`` if init may write it: not a folder, in a folder that exists, and new (or
    ``force``)."""
    from optdesign.errors import UsageError, shown
    from optdesign.outputs.checks import system_tree

    label = f"--out {shown(str(path))}"
    if not str(path) or "\0" in str(path):
        raise UsageError(f"{label}: is not a file name")
    if path.is_dir():
        raise UsageError(f"{label}: is a folder; give a file name such as my.yaml")
    tree = system_tree(os.path.realpath(path))
    if tree:
        raise UsageError(f"{label}: is under {tree}, not a place for a problem file")
    if path.exists() and not force:
        raise UsageError(f"{label}: exists; init never overwrites a file (--force does)")
    if not path.parent.is_dir():
        raise UsageError(f"{label}: the folder {shown(str(path.parent))} does not exist")
    return path


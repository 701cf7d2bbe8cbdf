"""The ``optdesign`` command: parses arguments, calls the library, maps outcomes to exit codes.

Exit codes (docs/contract.md): 0 success; 1 solved but infeasible or failed (the
result is still written); 2 bad input or usage, one line on stderr naming file and key.
"""
from __future__ import annotations

import argparse
import os
import sys
from importlib import import_module

from .errors import OptDesignError, ProblemError

#: Each command is a module with ``add_parser(subparsers)`` and ``run(args) -> exit code``.
COMMANDS = [
    "optdesign.commands.analyze",
    "optdesign.commands.solve",
    "optdesign.commands.driveline",
    "optdesign.commands.curves",
    "optdesign.commands.simulate",
    "optdesign.commands.bench",
    "optdesign.commands.pareto",
]


class _Parser(argparse.ArgumentParser):
    def error(self, message):          # usage errors: one line, exit 2
        self.exit(2, f"optdesign: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    from . import __version__

    parser = _Parser(prog="optdesign", description="Size the linkages of pulse CVTs.")
    parser.add_argument("--version", action="version", version=f"optdesign {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for name in COMMANDS:
        import_module(name).add_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    os.environ.setdefault("MPLBACKEND", "Agg")      # the command writes figures to files only
    try:
        return int(args.run(args))
    except ProblemError as exc:
        print(f"optdesign: {exc}", file=sys.stderr)
        return 2
    except OptDesignError as exc:
        print(f"optdesign: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("optdesign: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())

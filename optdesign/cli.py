"""The ``optdesign`` command: parses arguments, calls the library, maps outcomes to exit codes.

Exit codes (docs/contract.md): 0 success; 1 solved but infeasible or failed (the
result is still written), or the run could not finish (out of memory, a write that failed, an
internal error); 2 bad input or usage, one line on stderr naming file and key. Every failure
is one line on stderr; ``--debug`` adds the traceback. A valid file whose values look like a unit
mistake (:mod:`optdesign.problem.plausibility`) adds one warning line and goes on.
"""
from __future__ import annotations

from optdesign.outputs import phases  # first: its clock starts with the program

import argparse
import os
import sys
from importlib import import_module

from optdesign.errors import OptDesignError, ProblemError, UnitWarning, UsageError, shown

#: longest line the command writes on stderr
MAX_MESSAGE_CHARS = 1000

#: Each command is a module with ``add_parser(subparsers)`` and ``run(args) -> exit code``.
COMMANDS = [
    "optdesign.commands.init",
    "optdesign.commands.analyze",
    "optdesign.commands.solve",
    "optdesign.commands.driveline",
    "optdesign.commands.curves",
    "optdesign.commands.simulate",
    "optdesign.commands.bench",
    "optdesign.commands.pareto",
    "optdesign.commands.tolerance",
    "optdesign.commands.export",
    "optdesign.commands.animate",
    "optdesign.commands.compare",
    "optdesign.commands.atlas",
    "optdesign.explorer.command",
    "optdesign.commands.schema",
    "optdesign.commands.server",
    "optdesign.commands.warmup",
]


class _Parser(argparse.ArgumentParser):
    def error(self, message):          # usage errors: one line, exit 2
        self.exit(2, one_line(f"optdesign: {message}") + "\n")


def build_parser() -> argparse.ArgumentParser:
    from optdesign import __version__

    parser = _Parser(prog="optdesign", description="Size the linkages of pulse CVTs.")
    parser.add_argument("--version", action="version", version=f"optdesign {__version__}")
    parser.add_argument("--debug", action="store_true",
                        help="print the traceback of any failure (for a bug report)")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for name in COMMANDS:
        import_module(name).add_parser(sub)
    for command in sub.choices.values():     # --debug after the command too
        command.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                             help="print the traceback of any failure (for a bug report)")
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the command of ``argv``. Run as the program (``argv`` None), hand it to the warm
    server when one is listening (:mod:`optdesign.warm`), else run it here and start one."""
    if argv is None:
        from optdesign.outputs import streams
        streams.guard()                 # a closed or ASCII-only stream fails no result
        code = _delegated()
        if code is not None:
            phases.handed_over()
            _exit_now(code)
    import warnings

    args = build_parser().parse_args(argv)
    with warnings.catch_warnings():
        warnings.simplefilter("always", UnitWarning)
        shown_before = warnings.showwarning
        warnings.showwarning = lambda message, category, *rest, **kw: (
            _warn(message) if issubclass(category, UnitWarning)
            else shown_before(message, category, *rest, **kw))
        code = _run(args, argv)
    if argv is None:        # run as the `optdesign` program: its work is done
        from optdesign.warm.client import start_server_if_missing
        start_server_if_missing()
        _exit_now(code)
    return code


def serve_warm() -> None:
    """The warm server's process (:mod:`optdesign.warm.server`): it runs this command line."""
    from optdesign.warm import child, server
    server.main(child.Program(main=main, exit_now=_exit_now, parser=build_parser))


def _delegated() -> int | None:
    """The exit code of the command as the warm server ran it, or None to run it here."""
    from optdesign.warm import client, place

    try:
        return client.delegate(sys.argv[1:], phases.started())
    except place.SettingError as exc:
        print(one_line(f"optdesign: {exc}"), file=sys.stderr, flush=True)
        return 2
    except KeyboardInterrupt:           # Ctrl-C before the command was handed over
        print("optdesign: interrupted", file=sys.stderr, flush=True)
        return 130


def _exit_now(code: int) -> None:
    """End the program with ``code`` at once. The exit handlers run and stdout and stderr are
    flushed, as at any exit (a pool's clean-up, the phase clock's line); what is skipped is
    the interpreter's teardown, which clears the modules of CasADi, SciPy and matplotlib one
    by one after the last line is out (0.1-0.2 s, a sixth of ``analyze``) and frees nothing
    the end of the process does not."""
    import atexit

    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):   # a closed pipe: the exit code tells
            pass
    os._exit(code)


def _warn(message) -> None:
    """A problem file's likely unit mistake: one line on stderr, and the command goes on."""
    try:
        print(one_line(f"optdesign: warning: {message}"), file=sys.stderr, flush=True)
    except (OSError, ValueError):
        pass


def _run(args, argv) -> int:
    """The command of ``args``, its outcome mapped to an exit code; under --debug with the
    library's debug lines on stderr."""
    if not getattr(args, "debug", False):
        return _run_command(args, argv)
    import logging

    logger, handler = logging.getLogger("optdesign"), _stderr_handler()
    handler.setFormatter(logging.Formatter("optdesign: debug: %(message)s"))
    level = logger.level
    logger.addHandler(handler)
    logger.setLevel(logging.DEBUG)
    try:
        return _run_command(args, argv)
    finally:
        logger.removeHandler(handler)
        logger.setLevel(level)


def _run_command(args, argv) -> int:
    """The command of ``args``, its outcome mapped to an exit code."""
    if argv is None:        # run as the `optdesign` program: it writes figures to files only
        os.environ.setdefault("MPLBACKEND", "Agg")
        # a figure's layout warning is no line for the user's stderr: the figure is written
        import warnings
        warnings.filterwarnings("ignore", category=UserWarning, module="matplotlib")
    try:
        code = int(args.run(args))
        sys.stdout.flush()              # a closed pipe shows here, not at exit
        return code
    except BrokenPipeError:             # `optdesign analyze P.yaml | head`: quietly
        _silence_stdout()
        return 1
    except KeyboardInterrupt:
        return _fail(args, "optdesign: interrupted", 130)
    except (ProblemError, UsageError) as exc:
        return _fail(args, f"optdesign: {exc}", 2)
    except OptDesignError as exc:
        return _fail(args, f"optdesign: {exc}", 1)
    except MemoryError:
        return _fail(args, f"optdesign {args.command}: out of memory", 1)
    except RecursionError:
        return _fail(args, _internal(args, "RecursionError", "nested too deep"), 1)
    except OSError as exc:              # a disk full, a folder removed under a running command
        name = exc.filename
        name = os.fsdecode(name) if isinstance(name, (str, bytes, os.PathLike)) else name
        where = f": {shown(name)}" if name is not None else ""
        return _fail(args, f"optdesign {args.command}: {exc.strerror or type(exc).__name__}"
                           f"{where}", 1)
    except Exception as exc:            # a bug: say so, and how to report it
        return _fail(args, _internal(args, type(exc).__name__, str(exc)), 1)


def _stderr_handler():
    """A logging handler writing to the stderr of the moment (a test or the warm server's
    child may have replaced the stream since the handler was made)."""
    import logging

    class Stderr(logging.StreamHandler):
        @property
        def stream(self):
            return sys.stderr

        @stream.setter
        def stream(self, value):
            pass

    return Stderr()


def _internal(args, kind: str, detail: str) -> str:
    return (f"optdesign {args.command}: internal error ({kind}: {shown(detail, 120)}); please "
            f"report it with the problem file and the command line"
            + ("" if args.debug else " (--debug prints the traceback)"))


def _fail(args, message: str, code: int) -> int:
    """Write ``message`` as one line on stderr (with the traceback before it under --debug)
    and return ``code``."""
    if getattr(args, "debug", False):
        import traceback
        traceback.print_exc()
    try:
        print(one_line(message), file=sys.stderr, flush=True)
    except (OSError, ValueError):       # stderr closed too: the exit code still tells
        pass
    return code


def one_line(message: str) -> str:
    """``message`` as one printable line of at most MAX_MESSAGE_CHARS characters (a file
    name may hold a newline, a value a megabyte)."""
    text = "".join(c if c.isprintable() else repr(c)[1:-1] for c in message)
    return text if len(text) <= MAX_MESSAGE_CHARS else text[:MAX_MESSAGE_CHARS - 3] + "..."


def _silence_stdout() -> None:
    """Point stdout at /dev/null, so the interpreter's last flush of what a closed pipe did
    not take raises nothing."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):   # not a real file (tests capture it)
        pass


if __name__ == "__main__":
    sys.exit(main())

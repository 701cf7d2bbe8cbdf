"""``optdesign pareto PROBLEM.yaml [--out DIR] [--points K] [--against QUANTITY]
[--workers W] [--resume] [--scheduler ADDRESS] [--no-report]``."""
from __future__ import annotations

import os
from pathlib import Path

from optdesign.limits import COUNTS, PROCESSES_PER_CORE
from optdesign.outputs.phases import phase

#: most ε values of --points, as pareto.points (the table, not the pareto package: that one
#: pulls in pandas, and building the parser must stay light)
MAX_POINTS = COUNTS["points"]


def add_parser(sub) -> None:
    p = sub.add_parser("pareto", help="sweep the ripple/ratio front of every phase count")
    p.add_argument("problem", help="problem file (YAML)")
    p.add_argument("--out", help="output folder (default results/NAME_pareto/)")
    p.add_argument("--force", action="store_true",
                   help="replace results of another problem file in the output folder")
    p.add_argument("--points", type=_positive(2, MAX_POINTS), help="ε values per phase count "
                                                        "(default: pareto.points, else 12)")
    p.add_argument("--against", metavar="QUANTITY",
                   help="trade the ripple against this quantity instead of the file's "
                        "pareto.against (the ratio by default), e.g. housing_radius")
    p.add_argument("--workers", type=_positive(1, COUNTS["workers"]),
                   help="worker processes (default: every core; a local pool starts at most "
                        f"{PROCESSES_PER_CORE} per core)")
    p.add_argument("--resume", action="store_true",
                   help="continue an interrupted sweep in --out without recomputing its points")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run the points on this Dask scheduler (needs optdesign[cluster])")
    p.add_argument("--no-report", action="store_true", help="pareto.csv/json only")
    p.set_defaults(run=run)


def _against(problem, path, name: str):
    """The problem swept against ``name``: its file's ``pareto:`` section with ``against``
    set, read again by the loader's rules (an unknown quantity, or ratio bounds beside
    another quantity, is named as the file's keys are)."""
    from optdesign.problem.loader import read_options
    from optdesign.problem.yaml_text import parse, read_text

    data = parse(read_text(Path(path)), problem.source)
    given = data.get("pareto") if isinstance(data, dict) else None
    section = dict(given) if isinstance(given, dict) else {}
    section["against"] = name
    return problem.with_options(read_options({"pareto": section},
                                             f"{problem.source}: --against", problem.method))


def _positive(low, high=None):
    def check(text):
        import argparse
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be an integer (got {text!r})") from None
        if value < low:
            raise argparse.ArgumentTypeError(f"must be at least {low} (got {value})")
        if high is not None and value > high:
            raise argparse.ArgumentTypeError(f"must be at most {high} (got {value})")
        return value
    return check


def run(args) -> int:
    with phase("imports"):
        from functools import partial

        from optdesign.errors import ProblemError
        from optdesign.lifetime import exit_on_sigterm
        from optdesign.outputs.answer import print_answer, raise_if_unprinted
        from optdesign.outputs.checks import prepare_out, resolve_out
        from optdesign.outputs.figure_process import FigureProcess
        from optdesign.outputs.folder import OutputFolder
        from optdesign.commands.files import PARETO_FILES, write_report
        from optdesign.problem.loader import load_problem

    with phase("reading"):
        problem = load_problem(args.problem)
        if args.against is not None:
            problem = _against(problem, args.problem, args.against)
    if not problem.free_lengths():          # nothing to trade: say so before any work
        raise ProblemError(f"{Path(args.problem).name}: design: a front needs a free length "
                           f"(give one a range, e.g. {{lower: 30, upper: 90}}); every length "
                           f"is fixed")
    out, _ = resolve_out(args.out, problem.name, "_pareto")
    if args.resume and not os.path.lexists(out / "points.jsonl"):
        raise ProblemError(f"{out / 'points.jsonl'}: nothing to resume (no journal there)")
    # a resumed sweep's journal checks whose it is itself
    out = prepare_out(args.out, problem.name, "_pareto", files=PARETO_FILES,
                      source=None if args.resume else args.problem, force=args.force,
                      record=False)
    with phase("imports"):
        # the sweep's worker (the solver and SciPy, most of a second), which its first point
        # would import: imported before the figures' process is forked, that process has it
        # too (the knee's figures evaluate the knee exactly) instead of importing SciPy's
        # optimisation package again in each figure's process after the sweep
        from optdesign.fronts import worker  # noqa: F401
    # the report's figures are drawn beside, by a process forked before any thread or worker
    # (a Dask client, the sweep's pool) exists; it imports matplotlib while the sweep runs
    with FigureProcess(enabled=not args.no_report, warm=partial(_warm_figures, problem)) \
            as figures:
        with phase("imports"):
            from optdesign.fronts import sweep
            from optdesign.fronts.files import front_files
            from optdesign.fronts.report import summary_text
            from optdesign.outputs.units import input_speed_text
        # one run at a time in ``out``; a fresh sweep clears the previous one's files first,
        # so the folder never holds files of two runs (docs/contract.md)
        with _connected(args.scheduler) as scheduler, exit_on_sigterm(), \
                OutputFolder(out, PARETO_FILES, args.problem) as folder:
            if not args.resume:
                folder.remove_owned()
            with phase("solving"):
                result = sweep(problem, out, points=args.points, workers=args.workers,
                               resume=args.resume, scheduler=scheduler)
            with phase("files"):
                files = front_files(out)            # the sweep wrote them as it ended
                print_answer(f"{problem.name}: {input_speed_text(problem.input_speed)}",
                             summary_text(result))
            if not args.no_report:
                command = " ".join(["optdesign pareto", args.problem, "--out", str(out)] + [
                    f"--{k} {getattr(args, k)}" for k in ("points", "against", "workers",
                                                          "scheduler")
                    if getattr(args, k)] + (["--resume"] if args.resume else []))
                with phase("figures"):
                    files += write_report(result, problem, out, problem_path=args.problem,
                                          command=command, figures=figures)
    raise_if_unprinted()
    print(f"wrote {', '.join(str(f) for f in files)}")
    return 0 if result.indicators["n_points"] else 1


def _warm_figures(problem) -> None:
    """The figures' process's warm-up while the sweep runs: matplotlib and the problem's
    kinematics (:func:`optdesign.figures.design.warm_up`), and what reading the report's jobs
    needs (pandas for the front's table, the report's plots): imported after the sweep, they
    held the figures back about 0.2 s (pareto_fourbar, 2 cores)."""
    import pandas  # noqa: F401

    import optdesign.commands.files  # noqa: F401
    import optdesign.fronts.report  # noqa: F401
    from optdesign.figures.design import warm_up

    warm_up(problem)


def _connected(address):
    """A Dask client of ``address`` checked within one deadline
    (:func:`optdesign.fronts.cluster.connect`; a context manager, ``None`` inside when no
    scheduler is given): an address that is malformed, silent or not a Dask scheduler is a
    usage error, found before any work."""
    from contextlib import nullcontext

    if address is None:
        return nullcontext(None)
    from optdesign.fronts.cluster import connect
    return connect(address)

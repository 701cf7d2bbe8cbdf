"""``optdesign solve PROBLEM.yaml [--out DIR] [--json] [--no-plots]``.

The answer comes first: the result is printed as soon as result.json, summary.txt and
design.yaml are written into the new set, and only then are the figures drawn, by a process
that imported matplotlib while the solver ran (:mod:`optdesign.outputs.figure_process`). The
set, figures included, replaces the folder's previous one whole when the last figure is
drawn; the ``wrote ...`` line follows.
"""
from __future__ import annotations

import sys

from optdesign.outputs.phases import phase


def add_parser(sub) -> None:
    p = sub.add_parser("solve", help="optimise the link lengths and phase count with IPOPT")
    p.add_argument("problem", help="problem file (YAML)")
    p.add_argument("--out", help="output folder (default results/NAME/)")
    p.add_argument("--force", action="store_true",
                   help="replace results of another problem file in the output folder")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--no-plots", action="store_true", help="skip the figures")
    p.set_defaults(run=run)


def run(args) -> int:
    with phase("imports"):
        from functools import partial

        from optdesign.commands.files import SOLVE_FILES
        from optdesign.figures.design import warm_up
        from optdesign.outputs.answer import raise_if_unprinted
        from optdesign.outputs.checks import prepare_out
        from optdesign.outputs.figure_process import FigureProcess
        from optdesign.problem.loader import load_problem

    with phase("reading"):
        problem = load_problem(args.problem)
        out = prepare_out(args.out, problem.name, files=SOLVE_FILES, source=args.problem,
                          force=args.force, record=False)     # before any work
    # the figures' process imports matplotlib while this one imports the solver and solves
    with FigureProcess(enabled=not args.no_plots, warm=partial(warm_up, problem)) as figures:
        with phase("imports"):
            from tqdm import tqdm

            from optdesign.lifetime import exit_on_sigterm, raise_if_terminated
            from optdesign.outputs.folder import OutputFolder
            from optdesign.outputs.progress_lines import CountLines
            from optdesign.solver import solve
        # one run at a time in ``out``; its set replaces the previous one whole
        # (docs/contract.md)
        with exit_on_sigterm(), OutputFolder(out, SOLVE_FILES, args.problem) as folder:
            with phase("solving"), tqdm(total=len(problem.counts()), desc="phase counts",
                                        unit="count", file=sys.stderr, disable=None,
                                        leave=False) as bar:
                result = solve(problem, progress=CountLines(bar, len(problem.counts())))
            raise_if_terminated()                     # nothing published after a SIGTERM
            if result.status != "optimal" and _holds_optimum(out):
                return _kept(result, problem, out, args)
            files = folder.replace_with(
                lambda into: _write(result, problem, into, args, figures))
    raise_if_unprinted()
    if not args.json:
        print(f"wrote {', '.join(str(f) for f in files)}")
    return 0 if result.status == "optimal" else 1


def _write(result, problem, into, args, figures) -> list:
    """The set, into the folder ``into``: the result's files, the answer printed, then the
    figures."""
    from optdesign.commands.files import draw_solve, write_solve
    from optdesign.outputs.answer import print_answer
    from optdesign.outputs.atomic import json_text
    from optdesign.solver.outputs import summary_text

    with phase("files"):
        files = write_solve(result, problem, into, plots=False, source_path=args.problem)
        print_answer(json_text(result.to_dict()) if args.json else
                     summary_text(result, problem))
    if not args.no_plots:
        with phase("figures"):
            files += draw_solve(result, problem, into, figures)
    return files


def _holds_optimum(out) -> bool:
    """True when the folder's result.json is an earlier optimum (of this problem file: the
    folder was claimed for it before the solve)."""
    import json

    try:
        return json.loads((out / "result.json").read_text()).get("status") == "optimal"
    except (OSError, ValueError, AttributeError):
        return False


def _kept(result, problem, out, args) -> int:
    """A run that found no optimum where an earlier one is: the earlier set stays whole,
    this run's result goes beside it as failed_result.json; exit 1."""
    from optdesign.outputs.answer import print_answer
    from optdesign.outputs.atomic import atomic_write_json, json_text
    from optdesign.solver.outputs import summary_text

    path = atomic_write_json(out / "failed_result.json", result.to_dict())
    print_answer(json_text(result.to_dict()) if args.json else summary_text(result, problem))
    print(f"optdesign: {problem.source}: {result.status}: the earlier optimum in {out} is "
          f"kept (its result.json and figures); this run's result is {path}", file=sys.stderr)
    return 1

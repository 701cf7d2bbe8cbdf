"""``optdesign bench accuracy [PROBLEM.yaml] [--json] [--out DIR] [--solve PROBLEM] [--quick]``.

Error of δ, the ratio and ω_min against run time for every evaluator (optdesign.analyses.accuracy).
"""
from __future__ import annotations

from optdesign.limits import COUNTS

DEFAULT_PROBLEM = "problems/sharkov2022.yaml"
#: most crank samples of --crosscheck
MAX_CROSSCHECK = COUNTS["crosscheck"]


def add_parser(sub) -> None:
    p = sub.add_parser("bench", help="benchmarks: error against run time of the evaluators")
    p.add_argument("what", choices=["accuracy"], help="which benchmark")
    p.add_argument("problem", nargs="?", default=DEFAULT_PROBLEM,
                   help=f"problem file whose design is evaluated (default {DEFAULT_PROBLEM})")
    p.add_argument("--json", action="store_true", help='print {"rows": [...]} as JSON')
    p.add_argument("--out", help="folder for accuracy.png and accuracy.json "
                                 "(default results/NAME/)")
    p.add_argument("--force", action="store_true",
                   help="replace results of another problem file in the output folder")
    p.add_argument("--solve", metavar="PROBLEM",
                   help="also time full solves of this problem (it needs free lengths)")
    p.add_argument("--crosscheck", type=int, default=0, metavar="N",
                   help="cross-check the reference by N crank samples (e.g. 2000000)")
    p.add_argument("--quick", action="store_true", help="fewer settings (a few seconds)")
    p.add_argument("--no-plot", action="store_true", help="skip the figure")
    p.set_defaults(run=run)


def run(args) -> int:
    import sys

    from tqdm import tqdm

    from optdesign.analyses.accuracy import accuracy_rows, evaluation_count, format_table
    from optdesign.errors import ProblemError, UsageError
    from optdesign.outputs.atomic import json_text
    from optdesign.outputs.checks import prepare_out
    from optdesign.outputs.folder import write_set
    from optdesign.commands.files import write_accuracy
    from optdesign.problem.loader import load_problem
    from optdesign.outputs.units import stamped

    problem = load_problem(args.problem)
    if args.crosscheck < 0:
        raise UsageError(f"--crosscheck must not be negative (got {args.crosscheck})")
    if args.crosscheck > MAX_CROSSCHECK:
        raise UsageError(f"--crosscheck must be at most {MAX_CROSSCHECK} "
                         f"(got {args.crosscheck})")
    solve_problem = load_problem(args.solve) if args.solve else None
    if solve_problem is not None and not solve_problem.free_lengths():
        raise ProblemError(f"{solve_problem.source}: --solve needs a problem with free lengths")
    out = prepare_out(args.out, problem.name, files=("accuracy.json", "accuracy.png"),
                      source=args.problem, force=args.force)
    # a bar on stderr over the evaluations, silent when stderr is not a terminal
    total = evaluation_count(quick=args.quick, solve=solve_problem is not None)
    with tqdm(total=total, desc="evaluations", unit="eval", file=sys.stderr, disable=None,
              leave=False) as bar:
        rows, ref = accuracy_rows(problem, crosscheck_samples=args.crosscheck,
                                  solve_problem=solve_problem, quick=args.quick,
                                  progress=bar.update)
    payload = stamped({"problem": problem.name, "reference": {
        "method": ref.method, **ref.figures.to_dict(), "crosscheck": ref.crosscheck},
        "rows": rows})
    files = write_set(out, ("accuracy.json", "accuracy.png"), lambda into: write_accuracy(
        payload, rows, problem, into, plot=not args.no_plot))
    if args.json:
        print(json_text(payload))
    else:
        print(format_table(rows, ref))
        print(f"wrote {', '.join(str(f) for f in files)}")
    return 0

"""``optdesign solve PROBLEM.yaml [--out DIR] [--json] [--no-plots]``."""
from __future__ import annotations

import sys


def add_parser(sub) -> None:
    p = sub.add_parser("solve", help="optimise the link lengths and phase count with IPOPT")
    p.add_argument("problem", help="problem file (YAML)")
    p.add_argument("--out", help="output folder (default results/NAME/)")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--no-plots", action="store_true", help="skip the figures")
    p.set_defaults(run=run)


def run(args) -> int:
    from optdesign.outputs.atomic import json_text
    from optdesign.outputs.checks import prepare_out
    from optdesign.problem.loader import load_problem
    from optdesign.solver import solve
    from optdesign.lifetime import exit_on_sigterm, raise_if_terminated
    from optdesign.outputs.folder import OutputFolder
    from optdesign.commands.files import SOLVE_FILES, write_solve
    from optdesign.solver.outputs import summary_text

    problem = load_problem(args.problem)
    out = prepare_out(args.out, problem.name, files=SOLVE_FILES)     # before any work
    # one run at a time in ``out``; its set replaces the previous one whole (docs/contract.md)
    with exit_on_sigterm(), OutputFolder(out, SOLVE_FILES) as folder:
        from tqdm import tqdm
        with tqdm(total=len(problem.counts()), desc="phase counts", unit="count",
                  file=sys.stderr, disable=None, leave=False) as bar:
            result = solve(problem, progress=bar.update)
        raise_if_terminated()                     # nothing published after a SIGTERM
        files = folder.replace_with(
            lambda into: write_solve(result, problem, into, plots=not args.no_plots,
                                     source_path=args.problem))
    if args.json:
        print(json_text(result.to_dict()))
    else:
        print(summary_text(result, problem))
        print(f"wrote {', '.join(str(f) for f in files)}")
    return 0 if result.status == "optimal" else 1

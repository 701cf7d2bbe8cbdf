"""``optdesign solve PROBLEM.yaml [--out DIR] [--json] [--no-plots]``."""
from __future__ import annotations

import json
import sys
from pathlib import Path


def add_parser(sub) -> None:
    p = sub.add_parser("solve", help="optimise the link lengths and phase count with IPOPT")
    p.add_argument("problem", help="problem file (YAML)")
    p.add_argument("--out", help="output folder (default results/NAME/)")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--no-plots", action="store_true", help="skip the figures")
    p.set_defaults(run=run)


def run(args) -> int:
    from ..problem import load_problem
    from ..solve import solve
    from ..outputs import write_solve
    from ..solve.outputs import summary_text

    problem = load_problem(args.problem)
    from tqdm import tqdm
    with tqdm(total=len(problem.counts()), desc="phase counts", unit="count", file=sys.stderr,
              disable=None, leave=False) as bar:
        result = solve(problem, progress=bar.update)
    out = Path(args.out) if args.out else Path("results") / problem.name
    files = write_solve(result, problem, out, plots=not args.no_plots)
    if args.json:
        print(json.dumps(result.to_dict(), indent=2))
    else:
        print(summary_text(result, problem))
        print(f"wrote {', '.join(str(f) for f in files)}")
    return 0 if result.status == "optimal" else 1

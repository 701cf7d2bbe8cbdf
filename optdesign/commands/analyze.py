"""``optdesign analyze PROBLEM.yaml [--json]``."""
from __future__ import annotations


def add_parser(sub) -> None:
    p = sub.add_parser("analyze", help="evaluate the problem's design exactly")
    p.add_argument("problem", help="problem file (YAML)")
    p.add_argument("--json", action="store_true", help="print the contract's JSON")
    p.set_defaults(run=run)


def run(args) -> int:
    from ..analysis import analyze, format_analysis
    from ..io import json_text
    from ..problem import load_problem

    problem = load_problem(args.problem)
    result = analyze(problem)
    if args.json:
        print(json_text(result.to_dict()))
    else:
        print(format_analysis(result, problem.name))
    return 0 if result.assembles else 1

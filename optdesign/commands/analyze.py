"""``optdesign analyze PROBLEM.yaml [--json] [--out DIR] [--design FILE [--point K | --knee]]``."""
from __future__ import annotations

from optdesign.commands.design_source import add_arguments, loaded
from optdesign.outputs.phases import answered, phase


def add_parser(sub) -> None:
    p = sub.add_parser("analyze", help="evaluate the problem's design exactly")
    p.add_argument("problem", help="problem file (YAML)")
    p.add_argument("--json", action="store_true", help="print the contract's JSON")
    p.add_argument("--out", help="also draw regulation.png, δ and the ratio against the "
                                 "eccentricity, into this directory")
    add_arguments(p)
    p.set_defaults(run=run)


def run(args) -> int:
    with phase("imports"):
        import scipy.optimize  # noqa: F401  (brentq, first used by the evaluation)

        from optdesign.analyses.analyze import analyze, format_analysis
        from optdesign.outputs.atomic import json_text
        from optdesign.problem.loader import load_problem  # noqa: F401  (read by loaded())

    with phase("reading"):
        problem, chosen = loaded(args, one_count=False)
    out = None
    if args.out is not None:
        from optdesign.outputs.checks import prepare_out
        out = prepare_out(args.out, problem.name, files=("regulation.png",))
    with phase("evaluating"):
        result = analyze(problem)
    if args.json:
        print(json_text(chosen.stamped(result.to_dict())))
    else:
        print(f"design: {chosen.source}")
        print(format_analysis(result, problem.name))
    answered()
    if out is not None and result.assembles:
        from optdesign.analyses.analyze import regulation_curve
        from optdesign.commands.files import write_regulation

        with phase("figures"):
            path = write_regulation(regulation_curve(problem), result.regulation_range,
                                    f"{problem.name}: δ and ratio against e", out)
        if not args.json:
            print(f"wrote {path}")
    if not result.assembles:
        return 1
    violated = [c["name"] for c in result.constraints if not c["satisfied"]]
    if violated:
        import sys

        print(f"optdesign: {problem.source}: the design violates {', '.join(violated)}",
              file=sys.stderr)
        return 1
    return 0

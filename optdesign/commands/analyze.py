"""``optdesign analyze PROBLEM.yaml [--json] [--out DIR] [--phases N] [--design FILE [--point K |
--knee]]``.

A file that admits several counts (``phases: {choices: [4, 5, 6, 8]}`` or ``{lower, upper}``)
is analysed at each: a table, one row per count, then the first count's details; the JSON keeps
the first count's keys as they were and adds ``per_count``. ``--phases N`` analyses one."""
from __future__ import annotations

from optdesign.commands.design_source import add_arguments, loaded
from optdesign.outputs.phases import answered, phase


def add_parser(sub) -> None:
    p = sub.add_parser("analyze", help="evaluate the problem's design exactly")
    p.add_argument("problem", help="problem file (YAML)")
    p.add_argument("--json", action="store_true", help="print the contract's JSON")
    p.add_argument("--out", help="also draw regulation.png, δ and the ratio against the "
                                 "eccentricity, into this directory")
    p.add_argument("--force", action="store_true",
                   help="replace results of another problem file in the output folder")
    p.add_argument("--phases", type=int, metavar="N",
                   help="analyse this count only (phases, sections or freewheels: one of the "
                        "file's admissible counts); default: every admissible count")
    add_arguments(p)
    p.set_defaults(run=run)


def run(args) -> int:
    with phase("imports"):
        import scipy.optimize  # noqa: F401  (brentq, first used by the evaluation)

        from optdesign.analyses.analyze import analyze_counts, format_analysis, format_counts
        from optdesign.outputs.atomic import json_text
        from optdesign.problem.loader import load_problem  # noqa: F401  (read by loaded())

    with phase("reading"):
        problem, chosen = loaded(args, one_count=False)
        if args.phases is not None:
            problem = one_count(problem, args.phases, chosen)
    out = None
    if args.out is not None:
        from optdesign.outputs.checks import prepare_out
        out = prepare_out(args.out, problem.name, files=("regulation.png",),
                          source=args.problem, force=args.force)
    with phase("evaluating"):
        result = analyze_counts(problem)
    if args.json:
        print(json_text(chosen.stamped(result.to_dict())))
    else:
        print(chosen.line(problem))
        if result.per_count:
            print(format_counts(result))
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
    if not result.assembles and not result.per_count:
        return 1
    violated = [c["name"] for c in result.constraints if not c["satisfied"]]
    if result.per_count:                # several counts: fails when none meets them all
        meets = [r for r in result.per_count
                 if r.assembles and all(c["satisfied"] for c in r.constraints)]
        violated = [] if meets else sorted({c["name"] for r in result.per_count
                                            for c in r.constraints if not c["satisfied"]})
        if not meets and not violated:
            return 1
    if violated:
        import sys

        every = " at every count" if result.per_count else ""
        print(f"optdesign: {problem.source}: the design violates {', '.join(violated)}{every}",
              file=sys.stderr)
        return 1
    return 0


def one_count(problem, count: int, chosen):
    """``problem`` at the count ``--phases`` names: one of its admissible counts (and the
    count of the ``--design`` given, if any); UsageError otherwise."""
    from optdesign.errors import UsageError

    key = problem.model.count_variable
    admissible = problem.counts()
    if count not in admissible:
        what = f"the count of {chosen.source}" if chosen.values is not None else \
            f"an admissible count of design.{key}"
        raise UsageError(f"{problem.source}: --phases {count} is not {what} (admissible: "
                         f"{', '.join(str(n) for n in admissible)})")
    return problem.with_design(**{key: count})

"""``optdesign driveline PROBLEM.yaml [--out DIR] [--json] [--design FILE [--point K |
--knee]]``: the shaft's figures in the
terminal (critical speed, margins, the speed check's verdict) and its figure, DIR/driveline.png.

Exit 0 whatever the verdict (it is printed, and is ``verdict`` in the JSON); 1 when the design
does not assemble (the shaft's own figures are still printed and drawn).
"""
from __future__ import annotations

from optdesign.commands.design_source import add_arguments, loaded
from optdesign.outputs.phases import phase


def add_parser(sub) -> None:
    p = sub.add_parser("driveline", help="the cardan shaft's critical speed, margins and speed "
                                         "check, and a plot of its bend and imbalance against "
                                         "its speed (needs a driveline: section)")
    p.add_argument("problem", help="problem file (YAML) with a driveline: section")
    p.add_argument("--out", help="output directory (default results/NAME/)")
    p.add_argument("--force", action="store_true",
                   help="replace results of another problem file in the output folder")
    p.add_argument("--json", action="store_true", help="print the figures as JSON")
    add_arguments(p)
    p.set_defaults(run=run)


def run(args) -> int:
    with phase("imports"):
        from optdesign.figures.design import warm_up
        from optdesign.outputs.answer import print_answer, raise_if_unprinted
        from optdesign.outputs.atomic import json_text
        from optdesign.outputs.checks import prepare_out
        from optdesign.outputs.figure_process import FigureProcess
        from optdesign.commands.files import write_driveline
        from optdesign.problem.loader import load_problem  # noqa: F401  (read by loaded())

    with phase("reading"):
        problem, chosen = loaded(args, one_count=False)
        section = problem.require_section("driveline")
    out = prepare_out(args.out, problem.name, files=("driveline.png",), source=args.problem,
                      force=args.force)
    # the figures' process imports matplotlib while this one evaluates the design
    with FigureProcess(warm=warm_up) as figures:
        with phase("imports"):
            import scipy.optimize  # noqa: F401  (brentq, first used by the evaluation)

            from optdesign.analyses.analyze import analyze
            from optdesign.driveline.report import driveline_report, format_driveline
        with phase("evaluating"):
            result = analyze(problem)
            path = out / "driveline.png"
            report = driveline_report(problem, result, figure=str(path))
        print_answer(json_text(chosen.stamped(report)) if args.json else
                     f"design: {chosen.source}\n{format_driveline(report)}")
        with phase("figures"):
            figures.draw([(write_driveline, (section, path),
                           {"operating_speed": report.get("operating_speed_rad_s"),
                            "speed_limit": report.get("speed_limit_rad_s")})])
            figures.wait()
    raise_if_unprinted()
    if not args.json:
        print(f"wrote {path}")
    return 0 if result.assembles else 1

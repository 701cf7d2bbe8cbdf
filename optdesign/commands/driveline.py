"""``optdesign driveline PROBLEM.yaml [--out DIR]``: the shaft's figure, DIR/driveline.png."""
from __future__ import annotations


def add_parser(sub) -> None:
    p = sub.add_parser("driveline", help="plot the cardan shaft's bend and imbalance "
                                         "against its speed (needs a driveline: section)")
    p.add_argument("problem", help="problem file (YAML) with a driveline: section")
    p.add_argument("--out", help="output directory (default results/NAME/)")
    p.set_defaults(run=run)


def run(args) -> int:
    from ..analysis import analyze
    from ..output_checks import prepare_out
    from ..outputs import write_driveline
    from ..problem import load_problem

    problem = load_problem(args.problem)
    section = problem.require_section("driveline")
    out = prepare_out(args.out, problem.name, files=("driveline.png",))
    result = analyze(problem)
    figures = result.sections["driveline"]
    path = out / "driveline.png"
    write_driveline(section, path, operating_speed=figures.get("operating_speed_rad_s"),
                 speed_limit=figures.get("speed_limit_rad_s"))
    print(f"wrote {path}")
    return 0

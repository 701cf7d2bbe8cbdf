"""``optdesign curves PROBLEM.yaml [--out DIR] [--design FILE [--point K | --knee]]``:
position, velocity and acceleration analogues."""
from __future__ import annotations

from optdesign.commands.design_source import add_arguments, loaded
from optdesign.limits import COUNTS
from optdesign.outputs.phases import answered, phase

#: most crank samples of --samples (a figure of 1441 is already smooth)
MAX_SAMPLES = COUNTS["curve_samples"]


def add_parser(sub) -> None:
    p = sub.add_parser("curves", help="plot θ, dθ/dφ, d²θ/dφ² of every output member and the "
                                      "freewheel output over a turn")
    p.add_argument("problem", help="problem file (YAML)")
    p.add_argument("--out", help="output directory (default results/NAME/)")
    p.add_argument("--force", action="store_true",
                   help="replace results of another problem file in the output folder")
    p.add_argument("--eccentricity", type=float, default=1.0,
                   help="fraction e of the regulating length (default 1)")
    p.add_argument("--samples", type=int, default=1441, help="crank samples (default 1441)")
    add_arguments(p)
    p.set_defaults(run=run)


def run(args) -> int:
    with phase("imports"):
        from optdesign.evaluation.design import Design
        from optdesign.errors import UsageError
        from optdesign.figures.design import warm_up
        from optdesign.outputs.checks import prepare_out
        from optdesign.outputs.figure_process import FigureProcess
        from optdesign.commands.files import write_curves
        from optdesign.problem.loader import MIN_ECCENTRICITY

    with phase("reading"):
        problem, chosen = loaded(args, one_count=False)
    if not 0 < args.eccentricity <= 1:
        raise UsageError(f"--eccentricity must lie in (0, 1] (got {args.eccentricity:g})")
    if args.eccentricity < MIN_ECCENTRICITY:
        raise UsageError(f"--eccentricity must be at least {MIN_ECCENTRICITY:g} "
                         f"(got {args.eccentricity:g})")
    if args.samples < 16:
        raise UsageError(f"--samples must be at least 16 (got {args.samples})")
    if args.samples > MAX_SAMPLES:
        raise UsageError(f"--samples must be at most {MAX_SAMPLES} (got {args.samples})")
    out = prepare_out(args.out, problem.name, files=("curves.png",), source=args.problem,
                      force=args.force)
    # the figures' process imports matplotlib while this one computes the curves
    with FigureProcess(warm=warm_up) as figures:
        with phase("evaluating"):
            from optdesign.analyses.curves import member_curves

            design = Design.from_problem(problem)
            design.check_assembly(args.eccentricity)  # AssemblyError: exit 1, names the chain
            curves = member_curves(design, problem.stroke, args.eccentricity, args.samples)
        with phase("figures"):
            figures.draw([(write_curves, (curves, f"{problem.name}: {problem.mechanism}, "
                                                  f"e = {args.eccentricity:g}", out))])
            path, = figures.wait()
    answered()
    print(chosen.line(problem))
    print(path)
    return 0

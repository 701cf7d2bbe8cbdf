"""``optdesign curves PROBLEM.yaml [--out DIR]``: position, velocity and acceleration analogues."""
from __future__ import annotations

from pathlib import Path


def add_parser(sub) -> None:
    p = sub.add_parser("curves", help="plot θ, dθ/dφ, d²θ/dφ² of every output member and the "
                                      "freewheel output over a turn")
    p.add_argument("problem", help="problem file (YAML)")
    p.add_argument("--out", help="output directory (default results/NAME/)")
    p.add_argument("--eccentricity", type=float, default=1.0,
                   help="fraction e of the regulating length (default 1)")
    p.add_argument("--samples", type=int, default=1441, help="crank samples (default 1441)")
    p.set_defaults(run=run)


def run(args) -> int:
    from ..curves import member_curves
    from ..design import Design
    from ..errors import ProblemError
    from ..outputs import write_curves
    from ..problem import load_problem

    problem = load_problem(args.problem)
    if not 0 < args.eccentricity <= 1:
        raise ProblemError(f"--eccentricity must lie in (0, 1] (got {args.eccentricity:g})")
    if args.samples < 16:
        raise ProblemError(f"--samples must be at least 16 (got {args.samples})")
    design = Design.from_problem(problem)
    design.check_assembly(args.eccentricity)          # AssemblyError: exit 1, names the chain
    curves = member_curves(design, problem.stroke, args.eccentricity, args.samples)
    out = Path(args.out) if args.out else Path("results") / problem.name
    path = write_curves(curves, f"{problem.name}: {problem.mechanism}, "
                                f"e = {args.eccentricity:g}", out)
    print(path)
    return 0

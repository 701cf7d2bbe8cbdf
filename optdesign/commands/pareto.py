"""``optdesign pareto PROBLEM.yaml [--out DIR] [--points K] [--workers W] [--resume]
[--scheduler ADDRESS] [--no-report]``."""
from __future__ import annotations

from pathlib import Path


def add_parser(sub) -> None:
    p = sub.add_parser("pareto", help="sweep the ripple/ratio front of every phase count")
    p.add_argument("problem", help="problem file (YAML)")
    p.add_argument("--out", help="output folder (default results/NAME_pareto/)")
    p.add_argument("--points", type=_positive(2), help="ε values per phase count "
                                                        "(default: pareto.points, else 12)")
    p.add_argument("--workers", type=_positive(1), help="local worker processes "
                                                         "(default: every core)")
    p.add_argument("--resume", action="store_true",
                   help="continue an interrupted sweep in --out without recomputing its points")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run the points on this Dask scheduler (needs optdesign[cluster])")
    p.add_argument("--no-report", action="store_true", help="pareto.csv/json only")
    p.set_defaults(run=run)


def _positive(low):
    def check(text):
        import argparse
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be an integer (got {text!r})") from None
        if value < low:
            raise argparse.ArgumentTypeError(f"must be at least {low} (got {value})")
        return value
    return check


def run(args) -> int:
    from ..errors import ProblemError
    from ..pareto import sweep
    from ..outputs import write_front, write_report
    from ..pareto.report import summary_text
    from ..problem import load_problem

    problem = load_problem(args.problem)
    out = Path(args.out) if args.out else Path("results") / f"{problem.name}_pareto"
    if args.resume and not (out / "points.jsonl").exists():
        raise ProblemError(f"{out / 'points.jsonl'}: nothing to resume (no journal there)")
    if args.scheduler:
        try:
            import distributed  # noqa: F401
        except ImportError:
            raise ProblemError("--scheduler needs dask distributed: pip install "
                               "'optdesign[cluster]'") from None
    result = sweep(problem, out, points=args.points, workers=args.workers,
                   resume=args.resume, scheduler=args.scheduler)
    files = write_front(result, out)
    if not args.no_report:
        command = " ".join(["optdesign pareto", args.problem, "--out", str(out)] + [
            f"--{k} {getattr(args, k)}" for k in ("points", "workers", "scheduler")
            if getattr(args, k)] + (["--resume"] if args.resume else []))
        files += write_report(result, problem, out, problem_path=args.problem,
                              command=command)
    print(summary_text(result))
    print(f"wrote {', '.join(str(f) for f in files)}")
    return 0 if result.indicators["n_points"] else 1

"""``optdesign driveline PROBLEM.yaml [--out DIR]``: the shaft's figure, DIR/driveline.png."""
from __future__ import annotations

import os
import tempfile
from pathlib import Path


def add_parser(sub) -> None:
    p = sub.add_parser("driveline", help="plot the cardan shaft's bend and imbalance "
                                         "against its speed (needs a driveline: section)")
    p.add_argument("problem", help="problem file (YAML) with a driveline: section")
    p.add_argument("--out", help="output directory (default results/NAME/)")
    p.set_defaults(run=run)


def run(args) -> int:
    from ..analysis import analyze
    from ..errors import ProblemError
    from ..problem import load_problem

    problem = load_problem(args.problem)
    section = problem.sections.get("driveline")
    if section is None:
        raise ProblemError(f"{problem.source}: driveline is required by this command "
                           f"(add a driveline: section)")
    result = analyze(problem)
    figures = result.sections["driveline"]
    out = Path(args.out) if args.out else Path("results") / problem.name
    out.mkdir(parents=True, exist_ok=True)
    path = out / "driveline.png"
    write_figure(section, path, operating_speed=figures.get("operating_speed_rad_s"),
                 speed_limit=figures.get("speed_limit_rad_s"))
    print(f"wrote {path}")
    return 0


def write_figure(section, path: Path, **marks) -> None:
    """Plot and save atomically: a temporary file in the same directory, then os.replace."""
    from ..driveline.plot import plot_driveline

    fig = plot_driveline(section, **marks)
    fd, tmp = tempfile.mkstemp(prefix=".driveline-", suffix=".png", dir=path.parent)
    os.close(fd)
    try:
        fig.savefig(tmp, format="png", dpi=120)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)      # mkstemp makes 0600; give the file usual rights
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise

"""``optdesign animate PROBLEM.yaml [--design FILE [--point K | --knee]] [--eccentricity E]
[--frames N] [--out DIR]``: the linkage over one crank turn.

Writes ``animation.html`` (self-contained: SVG and a script, nothing beside it),
``animation.gif`` and, when ffmpeg is on the PATH, ``animation.mp4``, each atomically, into DIR
(default results/NAME/): the rocker driving the output highlighted, the output speed traced
beside it (:mod:`optdesign.export.animation`). Exit 0; 1 when the design does not assemble;
2 for bad input.
"""
from __future__ import annotations

from optdesign.commands.design_source import add_arguments, checked_eccentricity, loaded
from optdesign.limits import COUNTS
from optdesign.outputs.phases import answered, phase

#: most frames of --frames
MAX_FRAMES = COUNTS["frames"]
#: most frames of the GIF and the MP4 (a turn in 5 s): each is drawn by matplotlib
MOVIE_FRAMES = 60


def add_parser(sub) -> None:
    p = sub.add_parser("animate", help="the linkage over one crank turn as a self-contained "
                                       "HTML page and a GIF (an MP4 with ffmpeg)")
    p.add_argument("problem", help="problem file (YAML)")
    add_arguments(p)
    p.add_argument("--eccentricity", type=float, default=1.0,
                   help="fraction e of the regulating length (default 1)")
    p.add_argument("--frames", type=int, default=120, help="frames of the turn (default 120)")
    p.add_argument("--out", help="output directory (default results/NAME/)")
    p.add_argument("--force", action="store_true",
                   help="replace results of another problem file in the output folder")
    p.set_defaults(run=run)


def run(args) -> int:
    with phase("imports"):
        import shutil

        from optdesign.errors import UsageError
        from optdesign.outputs.checks import prepare_out
        from optdesign.outputs.folder import write_set
        from optdesign.problem.loader import load_problem  # noqa: F401  (read by loaded())

    with phase("reading"):
        problem, chosen = loaded(args)
    checked_eccentricity(args.eccentricity)
    if not 8 <= args.frames <= MAX_FRAMES:
        raise UsageError(f"--frames must lie in [8, {MAX_FRAMES}] (got {args.frames})")
    names = ["animation.html", "animation.gif"] + (["animation.mp4"] if shutil.which("ffmpeg")
                                                   else [])
    out = prepare_out(args.out, problem.name, files=tuple(names), source=args.problem,
                      force=args.force)
    written = write_set(out, names, lambda into: write_animation(
        problem, into, args.eccentricity, args.frames,
        movies=tuple(n for n in names if not n.endswith(".html"))))
    answered()
    print(chosen.line(problem))
    print(f"wrote {', '.join(str(p) for p in written)}")
    return 0


def write_animation(problem, out, eccentricity: float = 1.0, frames: int = 120,
                    movies: tuple[str, ...] = (), html_name: str = "animation.html") -> list:
    """``html_name`` (and each of ``movies``: GIF or MP4 file names) of the problem's design in
    ``out``; what was written. AssemblyError (exit 1) when the design does not assemble."""
    import tempfile
    from pathlib import Path

    from optdesign.evaluation.design import Design
    from optdesign.evaluation.figures import evaluate, evaluate_problem
    from optdesign.evaluation.ripples import Ripple, ripples_of_evaluation
    from optdesign.export.animation import html_page, movie, turn, turn_title
    from optdesign.outputs.atomic import atomic_write_bytes, atomic_write_text

    with phase("evaluating"):
        design = Design.from_problem(problem)
        design.check_assembly(eccentricity)
        ev = evaluate_problem(problem)
        if ev.failure is None and eccentricity not in ev.eccentricities:
            drawn = evaluate(design, problem.stroke, problem.input_speed, (eccentricity,))
            ev.failure = drawn.failure
            ev.per_e += drawn.per_e
        if ev.failure is not None:
            raise ev.failure
        named = ripples_of_evaluation(problem, ev)
        each = list(named.each)
        if all(r.at != eccentricity for r in each):
            figures = ev.at(eccentricity).figures[problem.stroke]
            each.insert(0, Ripple(figures.ripple(problem.objective.ripple),
                                  problem.objective.ripple, eccentricity))
        outputs = tuple((r.at, f"output at e = {r.at:g}: {r.text(4)}") for r in each)
        title = turn_title(problem, design, ev.figures, named)
        data = turn(design, problem.stroke, problem.input_speed, eccentricity, frames, outputs)
    with phase("files"):
        written = [atomic_write_text(Path(out) / html_name, html_page(data, title))]
    if movies and frames > MOVIE_FRAMES:      # a movie's frames are drawn one by one: fewer
        data = turn(design, problem.stroke, problem.input_speed, eccentricity, MOVIE_FRAMES,
                    outputs)
    for name in movies:
        with phase("figures"), tempfile.TemporaryDirectory() as scratch:
            path = Path(scratch) / name
            movie(data, title, path, fps=max(8, round(len(data.phi_deg) / 5)))
            written.append(atomic_write_bytes(Path(out) / name, path.read_bytes()))
    return written

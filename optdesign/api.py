"""The Python API, what a notebook imports::

    from optdesign import load_problem, analyze, solve, pareto

    problem = load_problem("problems/sharkov2022_disc.yaml")
    result = solve(problem)              # SolveResult: .delta, .design, .to_frame(), .to_dict()
    result                               # in Jupyter: a table of the optimum per phase count
    front = pareto(problem, points=8)    # ParetoResult: .front, .knee, .to_frame()
    analyze(problem, result.design)      # AnalysisResult: the exact figures of one design
    explore(problem, result.design)      # in Jupyter: sliders, the linkage, δ, re-optimise

Every function takes a problem as a :class:`~optdesign.problem.loader.Problem`, a path to a problem
file, or a mapping with the file's keys (validated by the same loader: a bad key raises
:class:`~optdesign.errors.ProblemError` naming it). Nothing here selects a matplotlib backend
or writes a file unless asked to (``pareto(out=...)``). docs/api.md has the whole reference.
"""
from __future__ import annotations

import tempfile
from collections.abc import Mapping
from pathlib import Path

from optdesign.errors import ProblemError, shown
from optdesign.limits import COUNTS
from optdesign.problem.loader import (Options, Problem, Reader, load_problem as _load_file,
                                      problem_from_dict)

__all__ = ["Options", "analyze", "as_problem", "explore", "load_options", "load_problem",
           "pareto", "plot_front", "plot_mechanism", "plot_speeds", "sensitivities", "solve"]


def load_problem(source) -> Problem:
    """A problem from a file path, or from a mapping with the problem file's keys."""
    if isinstance(source, Problem):
        return source
    if isinstance(source, Mapping):
        return problem_from_dict(dict(source), where="<dict>")
    if isinstance(source, (str, Path)):
        return _load_file(source)
    raise TypeError(f"a problem is a Problem, a path or a mapping (got {type(source).__name__})")


as_problem = load_problem


def load_options(source) -> Options:
    """How a problem file says to solve it (its ``solver:`` and ``pareto:``) as an
    :class:`~optdesign.problem.loader.Options`, apart from the problem; ``source`` as
    :func:`load_problem` takes it."""
    return load_problem(source).method


def _with_options(problem: Problem, options) -> Problem:
    """``problem`` to be solved by ``options`` (an Options or a mapping; None: its own)."""
    return problem if options is None else problem.with_options(options)


def _design(problem: Problem, design) -> dict | None:
    """``design`` checked by the loader's rules (:meth:`Problem.checked_values`)."""
    return None if design is None else problem.checked_values(design)


def _eccentricity(problem: Problem, e) -> float:
    """An eccentricity fraction in (0, 1], as ``regulation.eccentricity`` takes it."""
    from optdesign.problem.loader import _read_regulation
    return _read_regulation(Reader(f"{problem.source}: argument"), {"eccentricity": [e]})[0][0]


def analyze(problem, design: Mapping | None = None):
    """Exact figures of the problem's own design, or of ``design`` (lengths and count; the
    keys a :class:`SolveResult` ``.design`` has). Returns an
    :class:`~optdesign.analyses.analyze.AnalysisResult`."""
    from optdesign.analyses.analyze import analyze as _analyze

    problem = load_problem(problem)
    return _analyze(problem, _design(problem, design))


def sensitivities(problem, design: Mapping | None = None):
    """Exact dδ/dl, d(ratio)/dl and d(transmission-angle margin)/dl for every length of the
    problem's own design, or of ``design``: a
    :class:`~optdesign.evaluation.sensitivity.Sensitivities` (``.to_dict()`` is the block of
    ``result.json``; a :class:`SolveResult` has its best design's as ``.sensitivities``)."""
    from optdesign.evaluation.sensitivity import sensitivities as _sensitivities

    problem = load_problem(problem)
    return _sensitivities(problem, problem.start_values() | (_design(problem, design) or {}))


def solve(problem, progress=None, *, options=None):
    """The best verified design over every admissible count
    (:func:`optdesign.solver.driver.solve`), or with ``minimize: phases`` the least count
    whose least δ meets the ripple cap (:func:`optdesign.solver.least_count.least_count`).
    ``progress``: called once per count solved.
    ``options``: how to solve it, apart from the problem (:class:`Options`, or a mapping
    ``{"solver": {...}}`` whose keys replace the file's); by default the file's own."""
    from optdesign.solver.entry import solve as _solve

    if progress is not None and not callable(progress):
        raise TypeError(f"progress must be a callable or None (got {type(progress).__name__})")
    return _solve(_with_options(load_problem(problem), options), progress=progress)


def pareto(problem, out=None, points: int | None = None, workers: int | None = 1,
           resume: bool = False, scheduler=None, progress: bool = False, *, options=None):
    """The front of ripple against ratio, or against ``pareto.against``'s quantity
    (:func:`optdesign.fronts.sweep.sweep`).

    ``out``: folder for the journal and pareto.csv/json (what ``--resume`` continues); by
    default a temporary folder, removed afterwards (the result is in memory). ``workers``: 1
    (default) solves in this process, None every core. ``options``: how to sweep it, apart
    from the problem (:class:`Options`, or a mapping ``{"solver": {...}, "pareto": {...}}``);
    by default the file's own."""
    from optdesign.fronts.section import DECLARATION
    from optdesign.fronts.sweep import sweep

    problem = _with_options(load_problem(problem), options)
    r = Reader(f"{problem.source}: argument")
    if points is not None:
        points = DECLARATION.key("points").read(r, points, "points")
    if workers is not None:
        workers = r.integer(workers, "workers", 1, COUNTS["workers"])
    for name, flag in (("resume", resume), ("progress", progress)):
        if not isinstance(flag, bool):
            raise TypeError(f"{name} must be true or false (got {type(flag).__name__})")
    if resume and out is None:
        raise ProblemError(f"{problem.source}: resume=True needs out, the folder of the "
                           f"journal to continue")
    if out is not None and not isinstance(out, (str, Path)):
        raise TypeError(f"out must be a path (got {type(out).__name__})")
    scheduler = _scheduler(scheduler)
    if out is not None:
        from optdesign.outputs.checks import prepare_out
        from optdesign.outputs.folder import OutputFolder

        # the command's checks and lock: a folder that cannot work (a file, /dev/null, a
        # planted link) is a UsageError before any work, and one run writes there at a time
        out = prepare_out(out, problem.name, "_pareto", files=FRONT_FILES, option="out")
        with OutputFolder(out, FRONT_FILES):
            return sweep(problem, out, points=points, workers=workers, resume=resume,
                         scheduler=scheduler, progress=progress)
    with tempfile.TemporaryDirectory(prefix="optdesign-pareto-") as tmp:
        return sweep(problem, tmp, points=points, workers=workers, scheduler=scheduler,
                     progress=progress)


#: the files pareto(out=...) writes in its folder: the journal and the front's tables
FRONT_FILES = ("points.jsonl", "pareto.csv", "pareto.json")


def _scheduler(scheduler):
    """``scheduler`` when it can name a Dask cluster: None, an address (checked when the
    sweep connects, :func:`optdesign.fronts.cluster.connect`) or a ``distributed.Client``."""
    if scheduler is None or isinstance(scheduler, str):
        return scheduler
    try:
        from distributed import Client
    except ImportError:
        Client = ()
    if not isinstance(scheduler, Client):
        raise TypeError(f"scheduler must be an address such as 'tcp://HOST:8786' or a "
                        f"distributed.Client (got {type(scheduler).__name__})")
    return scheduler


def _ax(ax):
    """``ax`` when a plot can draw into it: None (a new figure) or a matplotlib Axes."""
    if ax is not None:
        from matplotlib.axes import Axes
        if not isinstance(ax, Axes):
            raise TypeError(f"ax must be a matplotlib Axes or None (got {type(ax).__name__})")
    return ax


def plot_speeds(problem, design: Mapping | None = None, eccentricity: float = 1.0, ax=None,
                title: str | None = None):
    """Each rocker's driving speed and the output envelope over one crank turn, of the
    problem's own design or of ``design``; returns the matplotlib figure."""
    from optdesign.evaluation.design import Design
    from optdesign.figures.design import plot_speeds as _plot

    problem = load_problem(problem)
    return _plot(Design.from_problem(problem, _design(problem, design)), problem.stroke,
                 problem.input_speed, _eccentricity(problem, eccentricity), ax=_ax(ax),
                 title=title)


def plot_mechanism(problem, design: Mapping | None = None, angles_deg=(0, 90, 180, 270),
                   eccentricity: float = 1.0, title: str | None = None):
    """The linkage drawn to scale at a few crank angles; returns the matplotlib figure."""
    from optdesign.evaluation.design import Design
    from optdesign.figures.design import plot_mechanism as _plot

    problem = load_problem(problem)
    r = Reader(f"{problem.source}: argument")
    if not isinstance(angles_deg, (list, tuple)) or not 1 <= len(angles_deg) <= 12:
        raise ProblemError(f"{problem.source}: angles_deg must be a list of 1 to 12 crank "
                           f"angles in degrees (got {shown(angles_deg)})")
    angles = [r.number(a, "angles_deg") for a in angles_deg]
    return _plot(Design.from_problem(problem, _design(problem, design)), angles,
                 _eccentricity(problem, eccentricity), title=title)


def plot_front(front, ax=None, title: str | None = None):
    """δ against ratio of a :class:`~optdesign.fronts.front.ParetoResult`: every phase
    count's front, the overall non-dominated designs and the knee; returns the figure."""
    from optdesign.fronts.front import ParetoResult
    from optdesign.fronts.report import plot_fronts

    if not isinstance(front, ParetoResult):
        raise TypeError(f"plot_front takes what pareto() returns, a ParetoResult (got "
                        f"{type(front).__name__})")
    points = front.points.copy()
    points.attrs["knee"] = front.indicators.get("knee")
    return plot_fronts(points, ax=_ax(ax), title=title, axis=front.axis)


def explore(problem, design=None, front=None):
    """The live explorer of ``optdesign explore`` as a notebook widget (docs/explorer.md): a
    slider with a number field for every free length, the count, the drawn eccentricity and
    every constraint's bound; the linkage and its speeds; δ named as ``solve`` names it and
    every constraint's margin; re-optimise (IPOPT warm-started from the design shown),
    follow, save.

    ``problem``: a path, a mapping with the file's keys (its bounds are moved in that
    mapping and loaded again by the loader's rules), or a Problem (its file's mapping when
    the file is found and loads to the same problem, else the mapping written anew from
    the Problem: docs/explorer.md).
    ``design``: None (the file's own), a mapping of design keys (a :class:`SolveResult`'s
    ``.design``), or a result.json / design.yaml path. ``front``: the folder of a finished
    ``pareto`` run, its points drawn and loadable. Returns the Panel layout; displayed as a
    cell's last value it shows itself (Panel and Bokeh load their scripts into the notebook,
    nothing from the internet)."""
    import panel as pn

    from optdesign.explorer.front import front_points
    from optdesign.explorer.page import Page
    from optdesign.explorer.session import Session

    if front is not None and not isinstance(front, (str, Path)):
        raise TypeError(f"front must be a path (got {type(front).__name__})")
    session = Session.open(problem, design)
    shown_front = front_points(front, session.problem) if front is not None else None
    pn.extension(inline=True)
    return Page(session, shown_front, wide=False).layout

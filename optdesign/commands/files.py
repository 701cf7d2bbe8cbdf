"""Every file a command leaves behind, written here and only here, each one atomically.

One function per command's set of files; the commands decide where, this module decides what
goes into each file, and :mod:`optdesign.outputs.atomic` makes every write all-or-nothing. Figures are
drawn by the plotting functions of each package (which return a figure and never write); a
command's figures are jobs of a :class:`~optdesign.outputs.figure_process.FigureProcess` (drawn
beside the command when it passes one, here otherwise), each a module-level function of
picklable arguments.
"""
from __future__ import annotations

from pathlib import Path

from optdesign.outputs.atomic import (atomic_savefig, atomic_write_bytes, atomic_write_json,
                                      atomic_write_text)

#: every file ``solve`` may leave in its folder (the set :mod:`optdesign.outputs.folder` replaces)
SOLVE_FILES = ("result.json", "summary.txt", "design.yaml", "speeds.png", "mechanism.png",
               "animation.html", "failed_result.json")
#: every file ``pareto`` may leave in its folder (the set a fresh sweep clears)
PARETO_FILES = ("points.jsonl", "pareto.csv", "pareto.json", "fronts.png", "lengths.png",
                "knee_mechanism.png", "knee_speeds.png", "knee_animation.html", "report.md",
                "report.html")


def save_figure(fig, path: Path, **kwargs) -> Path:
    """Save ``fig`` atomically to ``path`` and close it, whatever happens."""
    try:
        return atomic_savefig(fig, path, **kwargs)
    finally:
        import matplotlib.pyplot as plt
        plt.close(fig)


def saved(plot, args: tuple, path: Path, save: dict | None = None) -> Path:
    """``plot(*args)`` saved to ``path`` with ``save``'s savefig options: one figure as a job
    of a :class:`~optdesign.outputs.figure_process.FigureProcess`."""
    return save_figure(plot(*args), path, **(save or {}))


def _drawer(figures):
    """``figures``, or one that draws in this process."""
    from optdesign.outputs.figure_process import FigureProcess

    return figures if figures is not None else FigureProcess(enabled=False)


# --------------------------------------------------------------------------- solve
def write_solve(result, problem, out_dir: str | Path, plots: bool = True,
                source_path=None) -> list[Path]:
    """result.json, summary.txt and (for a design) design.yaml (the problem file at
    ``source_path`` with the design fixed), then, with ``plots``, the figures of
    :func:`draw_solve` drawn here."""
    from optdesign.commands.design_source import design_yaml
    from optdesign.solver.outputs import summary_text

    out = Path(out_dir)
    written = [atomic_write_json(out / "result.json", result.to_dict()),
               atomic_write_text(out / "summary.txt", summary_text(result, problem) + "\n")]
    fixed = design_yaml(source_path, result)
    if fixed is not None:
        written.append(atomic_write_text(out / "design.yaml", fixed))
    if plots:
        written += draw_solve(result, problem, out)
    return written


def draw_solve(result, problem, out_dir: str | Path, figures=None) -> list[Path]:
    """speeds.png and mechanism.png of the optimum, drawn by ``figures`` (a
    :class:`~optdesign.outputs.figure_process.FigureProcess`; default: here), and
    animation.html (the optimum over one crank turn), written here meanwhile; nothing
    without a design."""
    if not result.design:
        return []
    out = Path(out_dir)
    figures = _drawer(figures)
    figures.draw([(_speeds_png, (problem, result.design, out / "speeds.png",
                                 f"{problem.name}: optimum")),
                  (_mechanism_png, (problem, result.design, out / "mechanism.png",
                                    f"{problem.name}: optimum"))])
    from optdesign.commands.animate import write_animation

    html = write_animation(problem.with_design(**result.design), out)
    return figures.wait() + html


def _speeds_png(problem, values: dict, path: Path, head: str) -> Path:
    """Each rocker's driving speed and the output envelope of the design ``values``: the
    output at every listed eccentricity (and the interval's worst), each labelled with its
    δ, the title with the problem's δ (:mod:`optdesign.evaluation.ripples`); the title and
    the labels also stored as the PNG's ``Title`` and ``Description`` text."""
    from optdesign.evaluation.design import Design
    from optdesign.evaluation.ripples import design_ripples
    from optdesign.figures.design import plot_speeds

    design = Design.from_problem(problem, values)
    named = design_ripples(problem, values)
    outputs = None
    title = head
    if named is not None:
        ratio = design_ratio(problem, values)
        title = f"{head}, ratio = {ratio:.4f}\n{named.worst.text(4)}"
        outputs = [(r.at, f"output at e = {r.at:g}: {r.text(4)}") for r in named.each]
    fig = plot_speeds(design, problem.stroke, problem.input_speed, title=title,
                      outputs=outputs)
    text = {"Title": title.replace("\n", "; ")}
    if outputs:
        text["Description"] = "\n".join(label for _, label in outputs)
    return save_figure(fig, path, metadata=text)


def design_ratio(problem, values: dict) -> float:
    """The exact ratio (at e = 1) of the problem's design ``values``."""
    from optdesign.evaluation.figures import evaluate_problem

    return evaluate_problem(problem, values).ratio


def _mechanism_png(problem, values: dict, path: Path, title: str) -> Path:
    """The linkage of the design ``values`` to scale: the figure of ``plot_mechanism``, in a
    figures' process rendered in two bands at once (the slowest figure of ``solve``); its
    title with the problem's δ named (:mod:`optdesign.evaluation.ripples`), also stored as
    the PNG's ``Title`` text."""
    from functools import partial

    from optdesign.evaluation.design import Design
    from optdesign.evaluation.ripples import design_ripples
    from optdesign.figures.design import BANDS, mechanism_figure
    from optdesign.outputs.figure_process import in_figures_process
    from optdesign.outputs.split_figure import save_split

    design = Design.from_problem(problem, values)
    named = design_ripples(problem, values)
    if named is not None:
        title = f"{title}: {named.worst.text(4)}"
    return save_split(partial(mechanism_figure, design, title=title), BANDS, path,
                      split=in_figures_process(), metadata={"Title": title})


# --------------------------------------------------------------------------- pareto
def write_report(result, problem, out_dir, problem_path=None,
                 command: str | None = None, figures=None) -> list[Path]:
    """fronts.png, lengths.png, knee_mechanism.png, knee_speeds.png (drawn by ``figures``,
    a :class:`~optdesign.outputs.figure_process.FigureProcess`; default: here),
    knee_animation.html (the knee over one crank turn, written here meanwhile), then
    report.md and report.html."""
    from optdesign.fronts.report import (blocks, plot_fronts, plot_lengths, render_html, render_md,
                                         run_info)

    out = Path(out_dir)
    points = result.points
    points.attrs["knee"] = result.indicators.get("knee")
    axis = result.axis
    jobs = {"fronts.png": (saved, (plot_fronts, (points, None, f"{problem.name}: ripple "
                                                                 f"against {axis.name}", axis),
                                   out / "fronts.png"))}
    free = problem.free_lengths()
    if free:
        bounds = {k: (problem.design[k].lower, problem.design[k].upper) for k in free}
        jobs["lengths.png"] = (saved, (plot_lengths, (points, bounds, None, f"{problem.name}: "
                                                      f"free lengths along the front", axis),
                                       out / "lengths.png"))
    knee = result.knee
    values = None
    if knee is not None:
        values = {k: float(knee[k]) for k in problem.model.lengths}
        values[problem.model.count_variable] = int(knee["count"])
        jobs["knee_mechanism.png"] = (_mechanism_png, (
            problem, values, out / "knee_mechanism.png", f"knee design, n = {int(knee['count'])}"))
        jobs["knee_speeds.png"] = (_speeds_png, (
            problem, values, out / "knee_speeds.png", "knee design"))
    figures = _drawer(figures)
    figures.draw(list(jobs.values()))
    html = []
    if values is not None:
        from optdesign.commands.animate import write_animation

        html = write_animation(problem.with_design(**values), out,
                               html_name="knee_animation.html")
    images = dict(zip(jobs, figures.wait()))
    if html:
        images["knee_animation.html"] = html[0]
    items = blocks(result, problem, run_info(problem, result, problem_path, command), images)
    return list(images.values()) + [
        atomic_write_text(out / "report.md", render_md(items)),
        atomic_write_text(out / "report.html", render_html(items))]


# --------------------------------------------------------------------------- simulate
def write_simulation(result, out: Path, plots: bool = True) -> list[Path]:
    """dynamics.json and the steady cycle as CSV, then, with ``plots``, the three figures of
    :func:`draw_simulation` drawn here."""
    import numpy as np

    written = [atomic_write_json(out / "dynamics.json", result.to_dict())]
    tr = result.trace
    cols = {"t_s": tr["t"], "phi_rad": tr["phi"], "omega_in": tr["omega_in"],
            "psi_rad": tr["psi"], "omega_out": tr["omega_out"]}
    for k, label in enumerate(result.labels):
        cols[f"eps_{label}"] = np.where(tr["engaged"][k], tr["eps"][k], np.nan)
    rows = np.column_stack(list(cols.values()))
    lines = [",".join(cols)] + [",".join(f"{v:.10g}" for v in row) for row in rows]
    written.append(atomic_write_text(out / "dynamics_cycle.csv", "\n".join(lines) + "\n"))
    if plots:
        written += draw_simulation(result, out)
    return written


def draw_simulation(result, out: Path, figures=None) -> list[Path]:
    """The figures (angles, speeds, loads, and the natural frequencies beside the pulse
    harmonics), drawn by ``figures`` (default: here)."""
    from optdesign.dynamics.plots import plot_angles, plot_loads, plot_speeds

    from optdesign.dynamics.resonance import plot_frequencies

    figures = _drawer(figures)
    jobs = [(saved, (plot, (result,), out / name, {"dpi": 120}))
            for name, plot in (("dynamics_angles.png", plot_angles),
                               ("dynamics_speeds.png", plot_speeds),
                               ("dynamics_loads.png", plot_loads))]
    if result.resonance:
        jobs.append((saved, (plot_frequencies, (result.resonance, result.name),
                             out / "dynamics_frequencies.png", {"dpi": 120})))
    figures.draw(jobs)
    return figures.wait()


# --------------------------------------------------------------------------- tolerance
#: every file ``tolerance`` writes in its folder
TOLERANCE_FILES = ("tolerance.json", "tolerance.csv", "tolerance.png")


def write_tolerance(doc: dict, frame, out: Path, plots: bool = True) -> list[Path]:
    """tolerance.json, the Monte Carlo parts as tolerance.csv and, with ``plots``, their
    histograms (:func:`draw_tolerance`) drawn here."""
    csv = frame.to_csv(index=False, float_format="%.10g")
    written = [atomic_write_json(out / "tolerance.json", doc),
               atomic_write_bytes(out / "tolerance.csv", csv.encode("utf-8"))]
    return written + (draw_tolerance(doc, frame, out) if plots else [])


def draw_tolerance(doc: dict, frame, out: Path, figures=None) -> list[Path]:
    """tolerance.png, the histograms of the parts, drawn by ``figures`` (default: here)."""
    from optdesign.tolerance.report import plot_tolerance

    figures = _drawer(figures)
    figures.draw([(saved, (plot_tolerance, (frame, doc), out / "tolerance.png",
                           {"dpi": 110}))])
    return figures.wait()


# --------------------------------------------------------------------------- the others
def write_accuracy(payload: dict, rows, problem, out: Path, plot: bool = True) -> list[Path]:
    """accuracy.json and accuracy.png of ``optdesign bench accuracy``."""
    from optdesign.analyses.accuracy import plot_accuracy

    files = [atomic_write_json(out / "accuracy.json", payload)]
    if plot:
        files.append(save_figure(plot_accuracy(rows, title=f"{problem.name}: δ error against "
                                                         f"run time"),
                                 out / "accuracy.png", dpi=120))
    return files


def write_driveline(section, path: Path, **marks) -> Path:
    """The shaft's figure (deflection and imbalance against speed)."""
    from optdesign.driveline.plot import plot_driveline

    return save_figure(plot_driveline(section, **marks), path, dpi=120, bbox_inches=None)


def write_regulation(curve: dict, worst: dict | None, title: str, out: Path) -> Path:
    """regulation.png (``analyze --out``): δ and the ratio against the eccentricity."""
    from optdesign.figures.design import plot_regulation

    return save_figure(plot_regulation(curve, worst, title=title), out / "regulation.png",
                       dpi=110)


def write_curves(curves, title: str, out: Path) -> Path:
    """curves.png: θ, dθ/dφ, d²θ/dφ² of every output member."""
    from optdesign.analyses.curves import plot_curves

    return save_figure(plot_curves(curves, title=title), out / "curves.png", dpi=110)

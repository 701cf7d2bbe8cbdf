"""Every file a command leaves behind, written here and only here, each one atomically.

One function per command's set of files; the commands decide where, this module decides what
goes into each file, and :mod:`optdesign.outputs.atomic` makes every write all-or-nothing. Figures are
drawn by the plotting functions of each package (which return a figure and never write).
"""
from __future__ import annotations

from pathlib import Path

from optdesign.outputs.atomic import (atomic_savefig, atomic_write_bytes, atomic_write_json,
                                      atomic_write_text)

#: every file ``solve`` may leave in its folder (the set :mod:`optdesign.outputs.folder` replaces)
SOLVE_FILES = ("result.json", "summary.txt", "design.yaml", "speeds.png", "mechanism.png",
               "animation.html")
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


# --------------------------------------------------------------------------- solve
def write_solve(result, problem, out_dir: str | Path, plots: bool = True,
                source_path=None) -> list[Path]:
    """result.json, summary.txt and (for a design) design.yaml (the problem file at
    ``source_path`` with the design fixed), speeds.png, mechanism.png and animation.html (the
    optimum over one crank turn)."""
    from optdesign.commands.design_source import design_yaml
    from optdesign.evaluation.design import Design
    from optdesign.solver.outputs import summary_text

    out = Path(out_dir)
    written = [atomic_write_json(out / "result.json", result.to_dict()),
               atomic_write_text(out / "summary.txt", summary_text(result, problem) + "\n")]
    fixed = design_yaml(source_path, result)
    if fixed is not None:
        written.append(atomic_write_text(out / "design.yaml", fixed))
    if plots and result.design:
        from optdesign.figures.design import plot_mechanism, plot_speeds

        design = Design.from_problem(problem, result.design)
        written.append(save_figure(
            plot_speeds(design, problem.stroke, problem.input_speed,
                        title=f"{problem.name}: optimum, δ = {result.delta:.4f}, "
                              f"ratio = {result.ratio:.4f}"), out / "speeds.png"))
        written.append(save_figure(plot_mechanism(design, title=f"{problem.name}: optimum"),
                                   out / "mechanism.png"))
        from optdesign.commands.animate import write_animation

        written += write_animation(problem.with_design(**result.design), out)
    return written


# --------------------------------------------------------------------------- pareto
def write_report(result, problem, out_dir, problem_path=None,
                 command: str | None = None) -> list[Path]:
    """fronts.png, lengths.png, knee_mechanism.png, knee_speeds.png, knee_animation.html (the
    knee over one crank turn), report.md and report.html."""
    from optdesign.evaluation.design import Design
    from optdesign.fronts.report import (blocks, plot_fronts, plot_lengths, render_html, render_md,
                                         run_info)
    from optdesign.figures.design import plot_mechanism, plot_speeds

    out = Path(out_dir)
    images = {}
    points = result.points
    points.attrs["knee"] = result.indicators.get("knee")
    axis = result.axis
    images["fronts.png"] = save_figure(
        plot_fronts(points, title=f"{problem.name}: ripple against {axis.name}", axis=axis),
        out / "fronts.png")
    free = problem.free_lengths()
    if free:
        images["lengths.png"] = save_figure(
            plot_lengths(points, {k: (problem.design[k].lower, problem.design[k].upper)
                                  for k in free},
                         title=f"{problem.name}: free lengths along the front", axis=axis),
            out / "lengths.png")
    knee = result.knee
    if knee is not None:
        values = {k: float(knee[k]) for k in problem.model.lengths}
        values[problem.model.count_variable] = int(knee["count"])
        design = Design.from_problem(problem, values)
        images["knee_mechanism.png"] = save_figure(
            plot_mechanism(design, title=f"knee design, n = {int(knee['count'])}"),
            out / "knee_mechanism.png")
        images["knee_speeds.png"] = save_figure(
            plot_speeds(design, problem.stroke, problem.input_speed,
                        title=f"knee design: δ = {knee['delta']:.4f}, "
                              f"ratio = {knee['ratio']:.4f}"), out / "knee_speeds.png")
        from optdesign.commands.animate import write_animation

        images["knee_animation.html"] = write_animation(
            problem.with_design(**values), out, html_name="knee_animation.html")[0]
    items = blocks(result, problem, run_info(problem, result, problem_path, command), images)
    return list(images.values()) + [
        atomic_write_text(out / "report.md", render_md(items)),
        atomic_write_text(out / "report.html", render_html(items))]


# --------------------------------------------------------------------------- simulate
def write_simulation(result, out: Path) -> list[Path]:
    """dynamics.json, the steady cycle as CSV and the three figures (angles, speeds,
    loads)."""
    import numpy as np

    from optdesign.dynamics.plots import plot_angles, plot_loads, plot_speeds

    written = [atomic_write_json(out / "dynamics.json", result.to_dict())]
    tr = result.trace
    cols = {"t_s": tr["t"], "phi_rad": tr["phi"], "omega_in": tr["omega_in"],
            "psi_rad": tr["psi"], "omega_out": tr["omega_out"]}
    for k, label in enumerate(result.labels):
        cols[f"eps_{label}"] = np.where(tr["engaged"][k], tr["eps"][k], np.nan)
    rows = np.column_stack(list(cols.values()))
    lines = [",".join(cols)] + [",".join(f"{v:.10g}" for v in row) for row in rows]
    written.append(atomic_write_text(out / "dynamics_cycle.csv", "\n".join(lines) + "\n"))
    for name, plot in (("dynamics_angles.png", plot_angles),
                       ("dynamics_speeds.png", plot_speeds),
                       ("dynamics_loads.png", plot_loads)):
        written.append(save_figure(plot(result), out / name, dpi=120))
    return written


# --------------------------------------------------------------------------- tolerance
#: every file ``tolerance`` writes in its folder
TOLERANCE_FILES = ("tolerance.json", "tolerance.csv", "tolerance.png")


def write_tolerance(doc: dict, frame, out: Path) -> list[Path]:
    """tolerance.json, the Monte Carlo parts as tolerance.csv and their histograms."""
    from optdesign.tolerance.report import plot_tolerance

    csv = frame.to_csv(index=False, float_format="%.10g")
    return [atomic_write_json(out / "tolerance.json", doc),
            atomic_write_bytes(out / "tolerance.csv", csv.encode("utf-8")),
            save_figure(plot_tolerance(frame, doc), out / "tolerance.png", dpi=110)]


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

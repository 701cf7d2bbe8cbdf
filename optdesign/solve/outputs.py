"""What ``optdesign solve`` leaves in its output folder, every file written atomically."""
from __future__ import annotations

from pathlib import Path

from ..design import Design
from ..io import atomic_savefig, atomic_write_json, atomic_write_text


def summary_text(result, problem) -> str:
    """A short plain-text account of a solve, for the terminal and summary.txt."""
    lines = [f"{problem.name}: {result.status} ({problem.mechanism}, {problem.stroke} stroke, "
             f"ω1 = {problem.input_speed:g} rad/s)"]
    if result.design:
        lines.append("design: " + ", ".join(f"{k} = {v:.4f}" if isinstance(v, float) else
                                            f"{k} = {v}" for k, v in result.design.items()))
        lines.append(f"δ ({problem.objective.ripple}, worst over e = "
                     f"{', '.join(f'{e:g}' for e in problem.eccentricities)}) = "
                     f"{result.delta:.6f}; ratio = {result.ratio:.6f}; least transmission "
                     f"angle = {result.min_transmission_angle_deg:.2f} deg")
    else:
        lines.append(result.message)
    lines.append(f"solve time {result.solve_time_s:.2f} s, {result.iterations} IPOPT iterations")
    lines.append("per phase count:")
    for p in result.per_phase:
        if p.status == "optimal":
            gap = f"{p.surrogate_gap:+.1e}" if p.surrogate_gap is not None else "n/a"
            lines.append(f"  n = {p.phases}: {p.status}, δ = {p.delta:.6f}, ratio = "
                         f"{p.ratio:.4f}, surrogate gap {gap}, {len(p.starts)} starts")
        else:
            lines.append(f"  n = {p.phases}: {p.status}: {p.message}")
    lines.append("every figure above is the exact evaluator's, not the NLP surrogate's")
    return "\n".join(lines)


def write_outputs(result, problem, out_dir: str | Path, plots: bool = True) -> list[Path]:
    """result.json, summary.txt and (for a design) speeds.png and mechanism.png."""
    out = Path(out_dir)
    written = [atomic_write_json(out / "result.json", result.to_dict()),
               atomic_write_text(out / "summary.txt", summary_text(result, problem) + "\n")]
    if plots and result.design:
        from ..plots import plot_mechanism, plot_speeds

        import matplotlib.pyplot as plt
        design = Design.from_problem(problem, result.design)
        fig = plot_speeds(design, problem.stroke, problem.input_speed,
                          title=f"{problem.name}: optimum, δ = {result.delta:.4f}, "
                                f"ratio = {result.ratio:.4f}")
        written.append(atomic_savefig(fig, out / "speeds.png"))
        plt.close(fig)
        fig = plot_mechanism(design, title=f"{problem.name}: optimum")
        written.append(atomic_savefig(fig, out / "mechanism.png"))
        plt.close(fig)
    return written

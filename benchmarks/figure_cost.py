"""What the figures of a solve cost in CPU: the least wall they can take after its answer.

``optdesign solve problems/sharkov2022_disc.yaml`` prints its answer, then waits for its two
figures: ``speeds.png``, and ``mechanism.png`` rendered as two bands by two processes and
joined (:mod:`optdesign.outputs.split_figure`). This measures the CPU time each part takes,
stage by stage, as the figures' process of the command meets it: each part is drawn in a
process forked from one that has done what that process does before its figures arrive
(the warm server's imports and first figure, :func:`optdesign.warm.server.preload`; the
problem's kinematics, :func:`optdesign.figures.design.warm_up`), so every measurement is a first drawing in its
process, as in the command (the optimum is solved in another child, so this process holds
no more than that one does). The stages:

* build: the figure and its artists (:func:`~optdesign.figures.design.plot_speeds`; one band
  of :func:`~optdesign.figures.design.mechanism_figure`, with the joint labels placed);
* measure: its tight box (:func:`optdesign.outputs.atomic.content_bbox`);
* render: Agg's pixels in that box;
* encode: the PNG (speeds.png; the joined mechanism.png).

Their sum is the CPU the figures need after the answer (the command draws nothing before it
knows its design). No schedule on the machine's cores draws them in less than that sum over
the cores; the latency target (``solve``'s wall at most 0.5 s beyond its ``solve_time_s``)
leaves the figures what the rest of the command beyond its solve does not take (start-up,
reading, files and the exit: the warm medians of ``benchmarks/command_latency.py``, read from
its results file when it is there). Writes benchmarks/results/figure_cost.md and .json.

    python benchmarks/figure_cost.py [--rounds 7]
"""
from __future__ import annotations

import argparse
import io
import json
import os
import platform
import statistics
import sys
import time
from pathlib import Path

from command_latency import TARGETS        # this folder is the script's: first on sys.path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
RESULTS = ROOT / "benchmarks" / "results"
PROBLEM = ROOT / "problems" / "sharkov2022_disc.yaml"
LATENCY = RESULTS / "command_latency.json"
#: seconds the target allows ``solve`` beyond its solve time
TARGET_S = TARGETS["solve sharkov2022_disc"]
DPI = 120
STAGES = ("build", "measure", "render", "encode")


def cpu() -> float:
    """This process's CPU time, user and system [s]."""
    return time.process_time()


def speeds_part(problem, design, title: str) -> dict:
    """speeds.png, as the command draws it (:func:`optdesign.commands.files._speeds_png`)."""
    from optdesign.figures.design import plot_speeds

    t = cpu()
    fig = plot_speeds(design, problem.stroke, problem.input_speed, title=title)
    return _measured_rendered(fig, t, encode=True)


def band_part(design, title: str, band: str) -> dict:
    """One band of mechanism.png, as one of its two processes draws it."""
    from optdesign.figures.design import mechanism_figure

    t = cpu()
    fig = mechanism_figure(design, title=title, bands=(band,))
    return _measured_rendered(fig, t, encode=False)


def join_part(design, title: str) -> dict:
    """The joined mechanism.png's PNG: the whole figure's pixels encoded (drawn unmeasured)."""
    from optdesign.figures.design import mechanism_figure

    rgba = _pixels(mechanism_figure(design, title=title))
    t = cpu()
    _png(rgba)
    return {"encode": cpu() - t}


def _measured_rendered(fig, t0: float, encode: bool) -> dict:
    from optdesign.outputs.atomic import content_bbox, padded

    out = {"build": cpu() - t0}
    t = cpu()
    box = padded(content_bbox(fig, DPI))
    out["measure"] = cpu() - t
    t = cpu()
    rgba = _pixels(fig, box)
    out["render"] = cpu() - t
    if encode:
        t = cpu()
        _png(rgba)
        out["encode"] = cpu() - t
    return out


def _pixels(fig, box=None):
    """``fig`` rendered by Agg at :data:`DPI` (cropped to ``box``, else to its tight box)."""
    import matplotlib.pyplot as plt
    import numpy as np

    from optdesign.outputs.atomic import content_bbox, padded

    box = box if box is not None else padded(content_bbox(fig, DPI))
    fig.savefig(io.BytesIO(), format="raw", dpi=DPI, bbox_inches=box)
    rgba = np.array(fig.canvas.buffer_rgba())
    plt.close(fig)
    return rgba


def _png(rgba) -> bytes:
    from matplotlib.image import imsave

    buf = io.BytesIO()
    imsave(buf, rgba, format="png", origin="upper", dpi=DPI)
    return buf.getvalue()


def in_child(fn, *args):
    """``fn(*args)`` in a forked child of this process, its value returned (a first drawing in
    a process that is warm as the figures' process is)."""
    from optdesign.lifetime import beside

    return beside(fn, *args)()


def solved(problem):
    """The disc problem's optimum, solved in a child: this process keeps only what the
    figures' process of the command holds when its figures arrive."""
    from optdesign.api import solve

    result = solve(problem)
    return {"design": result.design, "delta": result.delta, "ratio": result.ratio}


def warm_as_the_command(problem) -> None:
    """What the figures' process of a warm ``solve`` holds: what the warm server imports and
    draws (:func:`optdesign.warm.server.preload`), then the problem's kinematics
    (:func:`optdesign.figures.design.warm_up`)."""
    from optdesign.cli import build_parser, main
    from optdesign.figures.design import warm_up
    from optdesign.warm import child, server

    server.preload(child.Program(main=main, exit_now=os._exit, parser=build_parser))
    warm_up(problem)


def measure(rounds: int) -> dict:
    """Each part's stages [CPU s], every round's, and the design drawn."""
    import matplotlib

    matplotlib.use("Agg")
    from optdesign.api import load_problem
    from optdesign.evaluation.design import Design

    problem = load_problem(str(PROBLEM))
    result = in_child(solved, problem)
    warm_as_the_command(problem)
    design = Design.from_problem(problem, result["design"])
    title = (f"{problem.name}: optimum, δ = {result['delta']:.4f}, "
             f"ratio = {result['ratio']:.4f}")
    parts = {"speeds.png": (speeds_part, problem, design, title),
             "mechanism.png, upper band": (band_part, design, f"{problem.name}: optimum",
                                           "upper"),
             "mechanism.png, lower band": (band_part, design, f"{problem.name}: optimum",
                                           "lower"),
             "mechanism.png, the joined PNG": (join_part, design,
                                               f"{problem.name}: optimum")}
    runs = {name: [] for name in parts}
    for _ in range(rounds):
        for name, (fn, *args) in parts.items():
            runs[name].append(in_child(fn, *args))
    return {"design": result["design"], "count": design.count, "runs": runs}


def rest_beyond_solve() -> float | None:
    """The warm ``solve``'s median wall beyond its solve time that is not its figures (the
    start-up, reading, files and exit), from command_latency's results; None without them."""
    if not LATENCY.is_file():
        return None
    doc = json.loads(LATENCY.read_text())
    row = next((r for r in doc.get("warm_rows", []) if r["case"] == "solve sharkov2022_disc"),
               None)
    if row is None:
        return None
    rest = [r["wall_s"] - r["solve_time_s"]
            - sum(end - start for name, start, end in r["phases"] if name == "figures")
            for r in row["runs"] if r["phases"] and r["solve_time_s"] is not None]
    return statistics.median(rest) if rest else None


def tables(measured: dict, cores: int, rest: float | None) -> tuple[list[str], dict]:
    rows, total = [], 0.0
    for name, runs in measured["runs"].items():
        medians = {s: statistics.median(r[s] for r in runs) if s in runs[0] else None
                   for s in STAGES}
        part = sum(v for v in medians.values() if v is not None)
        total += part
        rows.append((name, medians, part))
    floor = total / cores
    rounds = len(next(iter(measured["runs"].values())))
    lines = [f"CPU time [s] of the disc problem's figures after its answer, stage by stage "
             f"(medians of {rounds} rounds, each part a first drawing in a process forked "
             f"from a warm one):", "",
             "| part | " + " | ".join(STAGES) + " | total |",
             "|---|" + "---|" * (len(STAGES) + 1)]
    for name, medians, part in rows:
        lines.append(f"| {name} | " + " | ".join(
            "-" if medians[s] is None else f"{medians[s]:.3f}" for s in STAGES)
            + f" | {part:.3f} |")
    lines.append(f"| all | | | | | {total:.3f} |")
    summary = {"cpu_s": total, "cores": cores, "floor_s": floor, "rest_beyond_solve_s": rest}
    lines += ["", f"The least wall of the figures after the answer, on {cores} cores (their CPU "
                  f"over the cores, nothing else running), against the latency target [s]:", "",
              "| | s |", "|---|---|",
              f"| the figures' CPU after the answer | {total:.2f} |",
              f"| the least wall it takes on {cores} cores | {floor:.2f} |"]
    if rest is not None:
        summary |= {"least_beyond_solve_s": rest + floor, "figures_budget_s": TARGET_S - rest}
        lines += [f"| the rest of the warm `solve` beyond its solve time (start-up, reading, "
                  f"files, the exit; `benchmarks/command_latency.py`) | {rest:.2f} |",
                  f"| the least wall of `solve` beyond its solve time | {rest + floor:.2f} |",
                  f"| the target | {TARGET_S:.2f} |",
                  f"| what the target leaves the figures | {TARGET_S - rest:.2f} |"]
    return lines, summary


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--out", type=Path, default=RESULTS / "figure_cost.md",
                    help="the results file (its JSON twin beside it)")
    args = ap.parse_args()
    measured = measure(args.rounds)
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (
        os.cpu_count() or 1)
    lines, summary = tables(measured, cores, rest_beyond_solve())
    meta = {"time": time.strftime("%Y-%m-%d %H:%M:%S"), "python": platform.python_version(),
            "machine": platform.machine() + " " + platform.system(), "cores": cores,
            "rounds": args.rounds}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("\n".join(lines) + "\n")
    args.out.with_suffix(".json").write_text(json.dumps(
        {"meta": meta, "summary": summary, **measured}, indent=2) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())

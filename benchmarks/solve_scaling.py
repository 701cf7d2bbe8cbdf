"""Solve time of `optdesign solve` against the phase count n and the crank samples N.

problems/sharkov2022_disc.yaml with the phase count replaced (n = 3, 4, 6, 8, 12, 16, 24 at the
file's samples), and with ``solver.samples`` replaced (N = 30, 45, 90, 180, 360 at n = 6).
Every solve runs in a fresh process (cold CasADi caches; the clock runs around
``solve(problem)`` alone, not the imports), one after the other. The ratio floor is the
file's 0.344; where a phase count is infeasible with it, the solve is repeated with 0.2 and
the table says so. Reported per run: status, exact δ (the result's, re-checked by
``optdesign.solver.verify``), ratio, IPOPT iterations, starts, wall time, and, when the
SolveResult carries ``timings_s`` (stage -> seconds: build, screening, ipopt, verification),
one column per stage.

    python benchmarks/solve_scaling.py [--quick] [--phases 3 4 6 ...] [--samples 30 45 ...]
        [--timeout 900]

Writes benchmarks/results/solve_scaling.{md,json} and docs/figures/solve_scaling.png
(``--quick``: n in 3, 4, 6, N in 45, 90, results to benchmarks/results/solve_scaling_quick.*).
"""
from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from optdesign.outputs.atomic import atomic_write_text  # noqa: E402
from optdesign.commands.files import save_figure  # noqa: E402
from optdesign.problem.loader import Variable, load_problem  # noqa: E402
from solve_vs_peers import timed_solve  # noqa: E402  (beside this script)

PROBLEM = ROOT / "problems" / "sharkov2022_disc.yaml"
PHASES = (3, 4, 6, 8, 12, 16, 24)
SAMPLES = (30, 45, 90, 180, 360)
SAMPLES_AT_N = 6
FALLBACK_RATIO = 0.2
STAGES = ("build", "screening", "ipopt", "verification")


def make_problem(phases: int, samples: int | None, min_ratio: float | None):
    problem = load_problem(PROBLEM)
    key = problem.model.count_variable
    problem = replace(problem, design={**problem.design, key: Variable(key, value=float(phases))})
    if samples is not None:
        problem = replace(problem, solver=replace(problem.solver, samples=samples))
    if min_ratio is not None:
        problem = problem.with_limit("ratio", "lower", min_ratio or None)
    return problem


def child(spec: str) -> None:
    """In a fresh process: one timed solve, then the exact re-check; JSON on stdout."""
    from optdesign.solver import verify

    phases, samples, min_ratio = json.loads(spec)
    problem = make_problem(phases, samples, min_ratio)
    r, run = timed_solve(problem)
    check = None
    if r.design is not None:
        v = verify(problem, r.design)
        check = {"feasible": bool(v.feasible), "delta": v.delta}
    print("@@RUN@@" + json.dumps(run | {"verified": check, "samples": problem.solver.samples,
                                        "min_ratio": problem.constraints.min_ratio}))


def run(phases: int, samples: int | None, timeout: float, log) -> dict:
    row = None
    for min_ratio in (None, FALLBACK_RATIO):
        spec = json.dumps([phases, samples, min_ratio])
        try:
            out = subprocess.run([sys.executable, __file__, "--_run", spec], capture_output=True,
                                 text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            row = {"status": f"timeout ({timeout:g} s)", "delta": None, "time_s": timeout,
                   "min_ratio": min_ratio, "timings": None}
            break
        line = next((x for x in out.stdout.splitlines() if x.startswith("@@RUN@@")), None)
        if line is None:
            row = {"status": "error", "error": out.stderr[-2000:], "delta": None,
                   "time_s": math.nan, "min_ratio": min_ratio, "timings": None}
            break
        row = json.loads(line[len("@@RUN@@"):])
        if row["status"] != "infeasible":
            break
        log(f"  n = {phases}: infeasible at the file's ratio floor; again with {FALLBACK_RATIO}")
    row.update({"phases": phases})
    log(f"  n = {phases}, N = {row.get('samples', samples)}: {row['status']} "
        f"δ = {row['delta']} in {row['time_s']:.2f} s")
    return row


def stage_keys(rows) -> list[str]:
    keys = []
    for r in rows:
        for k in (r.get("timings") or {}):
            if k not in keys:
                keys.append(k)
    return sorted(keys, key=lambda k: (STAGES.index(k) if k in STAGES else len(STAGES), k))


def table(rows, vary: str) -> str:
    stages = stage_keys(rows)
    head = [vary, "status", "exact δ", "verified", "ratio", "min_ratio", "iterations", "starts",
            "time [s]", "CPU [s]"] + [f"{k} [s]" for k in stages]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        v = r.get("verified") or {}
        cells = [str(r["phases"] if vary == "n" else r.get("samples")), r["status"],
                 "-" if r["delta"] is None else f"{r['delta']:.6f}",
                 "-" if not v else ("yes" if v["feasible"] else "NO"),
                 "-" if r.get("ratio") is None else f"{r['ratio']:.4f}",
                 f"{r['min_ratio']:g}" if r.get("min_ratio") is not None else "-",
                 str(r.get("iterations", "-")), str(r.get("starts", "-")),
                 f"{r['time_s']:.2f}", f"{r.get('cpu_s', math.nan):.2f}"]
        cells += [f"{(r.get('timings') or {}).get(k, math.nan):.2f}" for k in stages]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def figure(by_n, by_samples, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullLocator, ScalarFormatter

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for ax, rows, key, label in ((axes[0], by_n, "phases", "phase count n"),
                                 (axes[1], by_samples, "samples", f"crank samples N "
                                                                  f"(n = {SAMPLES_AT_N})")):
        ok = [r for r in rows if math.isfinite(r["time_s"])]
        if not ok:
            ax.axis("off")
            continue
        x = [r[key] for r in ok]
        ax.plot(x, [r["time_s"] for r in ok], "ko-", label="total")
        for k in stage_keys(ok):
            ax.plot(x, [(r.get("timings") or {}).get(k, math.nan) for r in ok], ".--", label=k)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xticks(x)
        ax.set_xticklabels([str(v) for v in x])
        ax.xaxis.set_minor_locator(NullLocator())
        ax.yaxis.set_major_formatter(ScalarFormatter())
        ax.ticklabel_format(axis="y", style="plain", useOffset=False)
        ax.set_xlabel(label)
        ax.set_ylabel("wall time [s]")
        ax.grid(True, which="both", alpha=0.3)
        for r in ok:
            if r["delta"] is not None:
                ax.annotate(f"δ={r['delta']:.5f}" + ("*" if r.get("min_ratio") ==
                                                     FALLBACK_RATIO else ""),
                            (r[key], r["time_s"]), textcoords="offset points", xytext=(0, 6),
                            ha="center", fontsize=7)
        ax.legend(fontsize=8)
    axes[0].set_title("solve time against the phase count")
    axes[1].set_title("solve time against the samples")
    fig.tight_layout()
    save_figure(fig, path, dpi=110, bbox_inches=None)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--phases", nargs="+", type=int, default=None)
    parser.add_argument("--samples", nargs="+", type=int, default=None)
    parser.add_argument("--timeout", type=float, default=900.0, help="per solve [s]")
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--_run", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args._run:
        child(args._run)
        return 0
    phases = args.phases or ((3, 4, 6) if args.quick else PHASES)
    samples = args.samples or ((45, 90) if args.quick else SAMPLES)
    log = lambda s: print(s, file=sys.stderr, flush=True)  # noqa: E731
    default_n = load_problem(PROBLEM).solver.samples
    log(f"against the phase count (N = {default_n}):")
    by_n = [run(n, None, args.timeout, log) for n in phases]
    for r in by_n:
        r.setdefault("samples", default_n)
    log(f"against the samples (n = {SAMPLES_AT_N}):")
    by_samples = []
    for N in samples:
        same = next((r for r in by_n if r["phases"] == SAMPLES_AT_N and
                     r.get("samples") == N), None)
        row = dict(same) if same else run(SAMPLES_AT_N, N, args.timeout, log)
        row["samples"] = N
        by_samples.append(row)
    header = (f"`optdesign solve` on {PROBLEM.name}, each solve in a fresh process, timed "
              f"around solve() alone; * or min_ratio {FALLBACK_RATIO}: infeasible at the "
              f"file's ratio floor.\n\n")
    md = (header + f"Against the phase count (N = {default_n}):\n\n" + table(by_n, "n") +
          f"\n\nAgainst the crank samples (n = {SAMPLES_AT_N}):\n\n" +
          table(by_samples, "N") + "\n")
    print(md)
    suffix = "_quick" if args.quick else ""
    out = ROOT / "benchmarks" / "results"
    atomic_write_text(out / f"solve_scaling{suffix}.md", md)
    meta = {"python": sys.version.split()[0], "time": time.strftime("%Y-%m-%d %H:%M:%S"),
            "problem": str(PROBLEM.relative_to(ROOT))}
    atomic_write_text(out / f"solve_scaling{suffix}.json",
                  json.dumps({"meta": meta, "by_phases": by_n, "by_samples": by_samples},
                             indent=1))
    fig_path = (out / "solve_scaling_quick.png") if args.quick else \
        ROOT / "docs" / "figures" / "solve_scaling.png"
    figure(by_n, by_samples, fig_path)
    log(f"wrote {out / f'solve_scaling{suffix}.md'}, .json and {fig_path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

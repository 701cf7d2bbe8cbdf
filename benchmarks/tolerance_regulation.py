"""The disc problem made to tolerance and regulated: docs/benchmarks.md's and docs/tolerance.md's
figures and table.

    python benchmarks/tolerance_regulation.py      # about 1 minute

Three designs of problems/sharkov2022_disc_tolerance.yaml (the disc problem, every length
± 0.05 mm, the crank ± 0.02 mm, uniform):

* **nominal**: ``optdesign solve`` of the file (δ held at e = 1 only);
* **robust**: the same with ``objective: {robust: worst_case}`` (the worst δ over the tolerance
  box minimised, every constraint held for every part of the box);
* **interval**: ``problems/sharkov2022_disc_interval.yaml``'s optimum (δ held over the whole
  regulation interval e in [0.2, 1]).

For each: the tolerance analysis (the exact worst case over the box for δ and for the least
transmission angle, a Monte Carlo of 10⁴ parts with the share below the 40° rule) and δ, the
ratio and the least transmission angle over e in [0.2, 1] (the exact worst e by the interval
search, and a 41-point curve). Writes benchmarks/results/tolerance_regulation.{md,json},
docs/figures/tolerance_disc.png (the parts' δ and least angle, nominal against robust) and
docs/figures/regulation_disc.png (δ and the ratio against e).
"""
from __future__ import annotations

import copy
import os
import sys
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from optdesign.evaluation.design import Design  # noqa: E402
from optdesign.outputs.atomic import atomic_savefig, atomic_write_json, atomic_write_text  # noqa: E402
from optdesign.problem.loader import load_problem, problem_from_dict  # noqa: E402
from optdesign.evaluation.regulation import curve_over_range, worst_over_range  # noqa: E402
from optdesign.solver import solve  # noqa: E402
from optdesign.tolerance.montecarlo import monte_carlo  # noqa: E402
from optdesign.tolerance.worst_case import worst_case  # noqa: E402

TOLERANCED = ROOT / "problems" / "sharkov2022_disc_tolerance.yaml"
INTERVAL = ROOT / "problems" / "sharkov2022_disc_interval.yaml"
RESULTS = ROOT / "benchmarks" / "results"
FIGURES = ROOT / "docs" / "figures"
E_RANGE = (0.2, 1.0)
PARTS, SEED = 10_000, 0


def problems():
    """The nominal, robust and interval problems (the robust one from the toleranced file)."""
    data = yaml.safe_load(TOLERANCED.read_text())
    robust = copy.deepcopy(data)
    robust["objective"]["robust"] = "worst_case"
    return {"nominal": load_problem(TOLERANCED),
            "robust": problem_from_dict(robust, where=str(TOLERANCED)),
            "interval": load_problem(INTERVAL)}


def analyse(name: str, problem, toleranced) -> dict:
    """Solve, then the tolerance analysis and the regulation curve of the optimum."""
    started = time.perf_counter()
    result = solve(problem)
    solve_s = time.perf_counter() - started
    design = result.design
    box = toleranced.sections["tolerances"]
    worst_delta = worst_case(toleranced, design, box, quantity="ripple")
    worst_angle = worst_case(toleranced, design, box, quantity="transmission_angle")
    parts = monte_carlo(toleranced, design, box, samples=PARTS, seed=SEED)
    ok = parts["assembles"].to_numpy()
    limit = toleranced.constraints.min_transmission_angle_deg
    d = Design.from_problem(toleranced, design)
    ripple = toleranced.objective.ripple
    over = worst_over_range(d, toleranced.stroke, toleranced.input_speed, ripple, *E_RANGE)
    curve = curve_over_range(d, toleranced.stroke, toleranced.input_speed, ripple,
                             np.linspace(*E_RANGE, 41))
    return {"name": name, "status": result.status, "solve_s": solve_s, "design": design,
            "delta": result.delta, "ratio": result.ratio,
            "min_angle_deg": result.min_transmission_angle_deg,
            "worst_delta": worst_delta.value, "worst_delta_deviation": worst_delta.deviation,
            "worst_angle_deg": worst_angle.value,
            "mc_delta_max": float(np.nanmax(parts["delta"])),
            "mc_delta_p95": float(np.nanpercentile(parts["delta"], 95)),
            "share_not_assembling": float(1 - ok.mean()),
            "share_below_angle": float((parts["mu_min_deg"][ok] < limit).mean()),
            "angle_limit_deg": limit,
            "range_worst_delta": over.delta, "range_worst_e": over.eccentricity,
            "range_min_angle_deg": over.min_angle_deg,
            "curve": {k: v.tolist() for k, v in curve.items()},
            "parts": {"delta": parts["delta"].tolist(), "mu": parts["mu_min_deg"].tolist()}}


LABELS = {"nominal": "nominal optimum (δ at e = 1)",
          "robust": "robust optimum (worst δ over the box)",
          "interval": "interval optimum (δ over e in [0.2, 1])"}
COLOURS = {"nominal": "tab:blue", "robust": "tab:green", "interval": "tab:purple"}


def report(rows: list[dict]) -> str:
    lines = ["The disc problem (problems/sharkov2022_disc_tolerance.yaml: every length ± 0.05 mm, "
             f"the crank ± 0.02 mm, uniform); {PARTS} Monte Carlo parts, seed {SEED}; the "
             "worst cases and the regulation range on the exact evaluator.", "",
             "| design | l0 | l2 | l2′ | l3 [mm] | δ | ratio | least μ [°] | worst δ over the box "
             "| Monte Carlo max δ | worst μ over the box [°] | parts below 40° | worst δ over "
             "e in [0.2, 1] (at e) |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        d = r["design"]
        lines.append(
            f"| {LABELS[r['name']]} | {d['l0']:.2f} | {d['l2']:.2f} | {d['l2_prime']:.2f} | "
            f"{d['l3']:.3f} | {r['delta']:.6f} | {r['ratio']:.4f} | {r['min_angle_deg']:.3f} | "
            f"{r['worst_delta']:.6f} | {r['mc_delta_max']:.6f} | {r['worst_angle_deg']:.3f} | "
            f"{100 * r['share_below_angle']:.1f} % | {r['range_worst_delta']:.6f} "
            f"({r['range_worst_e']:.3f}) |")
    return "\n".join(lines) + "\n"


def figures(rows: list[dict]) -> None:
    from optdesign.figures.design import pyplot

    plt = pyplot()
    by = {r["name"]: r for r in rows}
    fig, axes = plt.subplots(1, 2, figsize=(12, 3.9))
    for name in ("nominal", "robust"):
        r = by[name]
        for ax, key, worst in ((axes[0], "delta", r["worst_delta"]),
                               (axes[1], "mu", r["worst_angle_deg"])):
            values = np.asarray(r["parts"][key], dtype=float)
            ax.hist(values[np.isfinite(values)], bins=60, alpha=0.55, color=COLOURS[name],
                    label=LABELS[name])
            ax.axvline(worst, color=COLOURS[name], ls="--", lw=1.5,
                       label=f"its worst case ({worst:.4f})" if key == "delta" else
                       f"its worst case ({worst:.2f}°)")
    axes[1].axvline(rows[0]["angle_limit_deg"], color="darkorange", ls=":", lw=2,
                    label="the 40° rule")
    axes[0].set_xlabel("δ of the part (worst over the listed e)")
    axes[1].set_xlabel("least transmission angle μ of the part [deg]")
    axes[0].set_ylabel(f"parts (of {PARTS})")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.ticklabel_format(axis="x", useOffset=False)
        ax.legend(fontsize=7.5)
    fig.suptitle("The disc problem's optima made to ± 0.05 mm: nominal against robust")
    fig.tight_layout()
    atomic_savefig(fig, FIGURES / "tolerance_disc.png", dpi=120)
    plt.close(fig)

    fig, axes = plt.subplots(1, 2, figsize=(12, 3.9))
    for r in rows:
        c = r["curve"]
        e = np.asarray(c["eccentricity"])
        axes[0].plot(e, c["delta"], color=COLOURS[r["name"]], label=LABELS[r["name"]])
        axes[0].plot([r["range_worst_e"]], [r["range_worst_delta"]], "o",
                     color=COLOURS[r["name"]])
        axes[1].plot(e, c["ratio"], color=COLOURS[r["name"]], label=LABELS[r["name"]])
    axes[0].set_ylabel("δ (midrange)")
    axes[1].set_ylabel("ratio (output / input speed)")
    for ax in axes:
        ax.set_xlabel("eccentricity e (share of the crank l1)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7.5)
    axes[0].set_title("δ over the regulation range (dot: the exact worst e)", fontsize=10)
    axes[1].set_title("the ratio falls with e to 0", fontsize=10)
    fig.tight_layout()
    atomic_savefig(fig, FIGURES / "regulation_disc.png", dpi=120)
    plt.close(fig)


def main() -> int:
    probs = problems()
    rows = []
    for name, problem in probs.items():
        rows.append(analyse(name, problem, probs["nominal"]))
        print(f"{name}: solved in {rows[-1]['solve_s']:.1f} s", file=sys.stderr, flush=True)
    meta = {"python": sys.version.split()[0], "time": time.strftime("%Y-%m-%d %H:%M:%S"),
            "cores": os.cpu_count(), "command": "python benchmarks/tolerance_regulation.py"}
    slim = [{k: v for k, v in r.items() if k != "parts"} for r in rows]
    atomic_write_json(RESULTS / "tolerance_regulation.json", {"meta": meta, "rows": slim})
    text = report(rows)
    atomic_write_text(RESULTS / "tolerance_regulation.md", text)
    figures(rows)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""What a robust solve costs: its solve time against the nominal solve of the same file.

Two problems, each solved nominally (``objective.robust: none``) and robustly (``worst_case``),
alternated, each solve in a fresh process, ``--rounds`` times:

* ``problems/robust_fourbar.yaml``: a four-phase converter, every length ± 0.05 mm;
* ``problems/sharkov2022_disc_tolerance.yaml`` with ``robust: worst_case``: the disc problem,
  every length ± 0.05 mm, the crank ± 0.02 mm.

The table gives the median solve time (``solve_time_s``, the command's own figure), the IPOPT
iterations, the ratio of the medians, and the check of the robust optimum by the tolerance
analysis as ``optdesign tolerance`` runs it (a Monte Carlo of the box, then the worst part for δ
and for the transmission angle from its worst parts): its worst δ against the solve's
``worst_case_delta``, and its least angle against the rule. Writes
benchmarks/results/robust_cost.md and .json.

    python benchmarks/robust_cost.py [--rounds 5]
"""
from __future__ import annotations

import argparse
import json
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"

#: (label, problem file): each solved with robust none and worst_case
CASES = [("four-phase converter ± 0.05 mm (robust_fourbar)", "problems/robust_fourbar.yaml"),
         ("disc problem ± 0.05 mm (sharkov2022_disc_tolerance)",
          "problems/sharkov2022_disc_tolerance.yaml")]

#: one solve in a fresh interpreter: the problem's data on stdin, the result's JSON on stdout
SOLVE = """
import json, sys
from optdesign.problem.loader import problem_from_dict
from optdesign.solver import solve
data, where = json.load(sys.stdin)
r = solve(problem_from_dict(data, where=where))
print(json.dumps({"status": r.status, "solve_time_s": r.solve_time_s,
                  "iterations": r.iterations, "delta": r.delta,
                  "worst_case_delta": r.worst_case_delta, "design": r.design}))
"""


def variant(path: str, robust: str) -> dict:
    data = yaml.safe_load((ROOT / path).read_text())
    data["objective"]["robust"] = robust
    return data


def solve_once(data: dict, where: str) -> dict:
    done = subprocess.run([sys.executable, "-c", SOLVE], input=json.dumps([data, where]),
                          cwd=ROOT, capture_output=True, text=True, check=True)
    return json.loads(done.stdout)


def tolerance_check(data: dict, where: str, design: dict) -> dict:
    """The robust optimum's box as ``optdesign tolerance`` analyses it."""
    from optdesign.problem.loader import problem_from_dict
    from optdesign.tolerance.montecarlo import monte_carlo
    from optdesign.tolerance.worst_case import worst_case

    problem = problem_from_dict(data, where=where)
    section = problem.sections["tolerances"]
    frame = monte_carlo(problem, design, section)
    names = problem.model.lengths
    ok = frame[frame["assembles"]]
    found = {}
    for quantity, worst in (("ripple", ok.nlargest(8, "delta")),
                            ("transmission_angle", ok.nsmallest(8, "mu_min_deg"))):
        offsets = worst[[f"{k}_offset_mm" for k in names]].to_numpy()
        found[quantity] = worst_case(problem, design, section, quantity=quantity,
                                     candidates=offsets).value
    return {"worst_delta": found["ripple"], "worst_mu_deg": found["transmission_angle"],
            "rule_deg": problem.constraints.min_transmission_angle_deg}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    args = ap.parse_args()
    rows = []
    for label, path in CASES:
        runs = {"none": [], "worst_case": []}
        for _ in range(args.rounds):
            for robust in runs:
                runs[robust].append(solve_once(variant(path, robust), path))
        robust = runs["worst_case"][-1]
        if any(r["status"] != "optimal" for rs in runs.values() for r in rs):
            raise RuntimeError(f"{path}: a solve was not optimal")
        check = tolerance_check(variant(path, "worst_case"), path, robust["design"])
        median = {k: statistics.median(r["solve_time_s"] for r in rs) for k, rs in runs.items()}
        rows.append({"case": label, "file": path, "runs": runs, "median_solve_s": median,
                     "ratio": median["worst_case"] / median["none"],
                     "iterations": {k: rs[-1]["iterations"] for k, rs in runs.items()},
                     "nominal_delta": runs["none"][-1]["delta"],
                     "robust_worst_delta": robust["worst_case_delta"], "check": check})
    lines = [f"Solve time [s] (`solve_time_s`, median of {args.rounds} solves, nominal and "
             f"robust alternated, each in a fresh process) and the robust optimum checked by "
             f"the tolerance analysis of `optdesign tolerance`.", "",
             "| problem | nominal solve | robust solve | robust / nominal | IPOPT iterations "
             "(nominal, robust: its nominal stage included) | nominal δ | robust: worst δ over the box | the tolerance "
             "analysis: worst δ | its least μ [°] (rule) |", "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        m, c = r["median_solve_s"], r["check"]
        lines.append(f"| {r['case']} | {m['none']:.2f} | {m['worst_case']:.2f} | "
                     f"{r['ratio']:.1f}× | {r['iterations']['none']}, "
                     f"{r['iterations']['worst_case']} | {r['nominal_delta']:.6f} | "
                     f"{r['robust_worst_delta']:.6f} | {c['worst_delta']:.6f} | "
                     f"{c['worst_mu_deg']:.3f} ({c['rule_deg']:g}) |")
    RESULTS.mkdir(exist_ok=True)
    meta = {"time": time.strftime("%Y-%m-%d %H:%M:%S"), "python": platform.python_version(),
            "machine": platform.machine() + " " + platform.system(), "rounds": args.rounds}
    (RESULTS / "robust_cost.md").write_text("\n".join(lines) + "\n")
    (RESULTS / "robust_cost.json").write_text(json.dumps({"meta": meta, "rows": rows},
                                                         indent=2) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""A front's points warm-started from their neighbours' primal-dual optima, against cold runs.

The four fronts of the race (``benchmarks/pareto_vs_peers.py``), each swept in-process on one
worker (``--workers 1``, so every IPOPT run is this process's and can be counted) in a fresh
process, two ways in turn, ``--rounds`` times after one warm-up of each (not counted):

* **warm**: the code as it is (docs/pareto.md, "Warm starts");
* **cold**: the same code with the warm starts taken out (``PhaseSolver.solve_from`` called
  without its ``warm``), so every run starts as it did before them.

The first table gives the sweep's wall time (median over the rounds), IPOPT's own time in it
(the runs of ``PhaseSolver._ipopt``, median), the warm runs and how many of them took at most
five iterations, the median iterations of a warm run and of the cold sweep's runs from a
neighbour, and the ratios. The second compares the answers: the points of the two sweeps
matched by count and ε, the largest δ of a warm point above the cold point's (and below it),
and both hypervolumes. Writes benchmarks/results/warm_starts.md and .json.

    python benchmarks/warm_starts.py [--rounds 3]
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

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from optdesign.outputs.atomic import atomic_write_json, atomic_write_text  # noqa: E402

RESULTS = ROOT / "benchmarks" / "results"
FRONTS = ["pareto_fourbar", "pareto_disc_three_counts", "pareto_slotted_forward",
          "pareto_reverse_flat"]

#: one sweep in a fresh interpreter: argv (problem file, warm|cold); its JSON on stdout
SWEEP = r"""
import json, os, sys, tempfile, time
os.environ["OPTDESIGN_SERVER"] = "off"
from optdesign.fronts import sweep
from optdesign.problem.loader import load_problem
from optdesign.solver.phase_solver import PhaseSolver

path, how = sys.argv[1], sys.argv[2]
runs = []
solve_from, ipopt = PhaseSolver.solve_from, PhaseSolver._ipopt


def cold(self, *args, warm=None, **kwargs):
    return solve_from(self, *args, **kwargs)


def counted(self, *args, **kwargs):
    t0 = time.perf_counter()
    run = ipopt(self, *args, **kwargs)
    runs.append([bool(run.warm), run.iterations, time.perf_counter() - t0])
    return run


if how == "cold":
    PhaseSolver.solve_from = cold
PhaseSolver._ipopt = counted
problem = load_problem(path)
with tempfile.TemporaryDirectory() as out:
    t0 = time.perf_counter()
    sweep(problem, out, workers=1, progress=False)
    wall = time.perf_counter() - t0
    front = json.loads(open(os.path.join(out, "pareto.json")).read())
    journal = [json.loads(line) for line in open(os.path.join(out, "points.jsonl"))][1:]
points = {f"{r['count']} {r['epsilon']:.7f}": r["delta"] for r in journal
          if r.get("feasible") and r.get("epsilon") is not None and r["kind"] == "sweep"}
print(json.dumps({"wall_s": wall, "runs": runs, "points": points,
                  "hypervolume": front["indicators"]["hypervolume"],
                  "n_points": len(front["points"])}))
"""


def sweep_once(path: str, how: str) -> dict:
    done = subprocess.run([sys.executable, "-c", SWEEP, path, how], cwd=ROOT,
                          capture_output=True, text=True, check=True)
    return json.loads(done.stdout.splitlines()[-1])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()
    rows = []
    for name in FRONTS:
        path = f"problems/{name}.yaml"
        for how in ("warm", "cold"):            # the compiled libraries in the cache
            sweep_once(path, how)
        got = {"warm": [], "cold": []}
        for _ in range(args.rounds):
            for how in got:
                got[how].append(sweep_once(path, how))
                print(f"{name} {how}: {got[how][-1]['wall_s']:.2f} s", file=sys.stderr)
        warm, cold = got["warm"][-1], got["cold"][-1]
        common = sorted(set(warm["points"]) & set(cold["points"]))
        gaps = [warm["points"][k] - cold["points"][k] for k in common]
        warm_runs = [r for r in warm["runs"] if r[0]]
        rows.append({
            "front": name, "file": path,
            "wall_s": {h: statistics.median(r["wall_s"] for r in rs) for h, rs in got.items()},
            "ipopt_s": {h: statistics.median(sum(x[2] for x in r["runs"]) for r in rs)
                        for h, rs in got.items()},
            "runs": {h: len(got[h][-1]["runs"]) for h in got},
            "warm_runs": len(warm_runs),
            "warm_runs_within_5": sum(r[1] <= 5 for r in warm_runs),
            "warm_median_iterations": statistics.median(r[1] for r in warm_runs)
            if warm_runs else None,
            "cold_median_iterations": statistics.median(r[1] for r in cold["runs"]),
            "points": {h: got[h][-1]["n_points"] for h in got}, "matched": len(common),
            "unmatched": len(set(warm["points"]) ^ set(cold["points"])),
            "largest_delta_above": max(gaps, default=0.0),
            "largest_delta_below": -min(gaps, default=0.0),
            "hypervolume": {h: got[h][-1]["hypervolume"] for h in got}})
    lines = [f"Each front swept in-process on one worker, warm and cold in turn, each sweep in "
             f"a fresh process, median of {args.rounds} rounds after one warm-up each.", "",
             "| front | sweep, cold [s] | sweep, warm [s] | warm / cold | IPOPT, cold [s] | "
             "IPOPT, warm [s] | warm / cold | IPOPT runs (cold, warm) | warm runs: within 5 "
             "iterations | iterations a run, median: cold, warm runs |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        w, i = r["wall_s"], r["ipopt_s"]
        lines.append(f"| {r['front']} | {w['cold']:.2f} | {w['warm']:.2f} | "
                     f"{w['warm'] / w['cold']:.2f} | {i['cold']:.2f} | {i['warm']:.2f} | "
                     f"{i['warm'] / i['cold']:.2f} | {r['runs']['cold']}, {r['runs']['warm']} | "
                     f"{r['warm_runs_within_5']} of {r['warm_runs']} | "
                     f"{r['cold_median_iterations']:g}, {r['warm_median_iterations']:g} |")
    lines += ["", "| front | points (cold, warm) | ε points matched (unmatched) | largest δ "
              "of a warm point above the cold one's | below it | hypervolume, cold | "
              "hypervolume, warm |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['front']} | {r['points']['cold']}, {r['points']['warm']} | "
                     f"{r['matched']} ({r['unmatched']}) | {r['largest_delta_above']:.1e} | "
                     f"{r['largest_delta_below']:.1e} | {r['hypervolume']['cold']:.10f} | "
                     f"{r['hypervolume']['warm']:.10f} |")
    RESULTS.mkdir(exist_ok=True)
    meta = {"time": time.strftime("%Y-%m-%d %H:%M:%S"), "python": platform.python_version(),
            "machine": platform.machine() + " " + platform.system(), "rounds": args.rounds}
    atomic_write_text(RESULTS / "warm_starts.md", "\n".join(lines) + "\n")
    atomic_write_json(RESULTS / "warm_starts.json", {"meta": meta, "rows": rows})
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""The drive dynamics over the freewheel stiffness: explicit against implicit, and the sweep.

    PYTHONPATH=. python benchmarks/dynamics_stiffness.py [--turns 2] [--inertia 1e-4]
        [--damping 0.1] [--methods Radau,BDF,RK45] [--stiffness 1e2,1e3,...]
    PYTHONPATH=. python benchmarks/dynamics_stiffness.py --sweep [--jobs 2] [--quick]
        [--problems fourbar,reducer] [--variants ratchet,composite,"constant crank"]

Methods (the default): Sharkov & Kalinin's six-phase four-bar converter
(problems/sharkov2022.yaml) with the pulse reducer paper's motor and input inertia, a light
output (I2) and a 20 N·m load, simulated for a fixed number of crank turns from the same start
with each method at rtol 1e-8, atol 1e-10 rad. Prints one row per (stiffness, method):
accepted steps, right-hand-side evaluations, Jacobians, LU factorisations, switches, wall time,
and the dynamic δ of the last turn (the methods must agree on it), and writes them to
benchmarks/results/NAME.{md,json} (``--name``, default dynamics_methods; the undamped run of
docs/dynamics.md is ``--damping 0 --turns 1 --stiffness 1e2,1e4,1e5,1e6 --name
dynamics_methods_undamped``), whose tables docs/dynamics.md and docs/benchmarks.md show.

Sweep (``--sweep``): the promised range of ``optdesign simulate`` at the problem files' own
settings (100 turns at most, rtol 1e-8, atol 1e-10): stiffness 1e2 … 1e8 N·m/rad per decade ×
damping ratio {0, 0.1} × both dynamics problems × {Radau, BDF} × {ratchet freewheel and
dynamic crank, ``--freewheel composite``, ``--crank constant``}, each run the real command in
its own process. A run passes when it ends in exit 0 (steady) or exit 1 with one line on
stderr, strict JSON on stdout (no NaN or Infinity) and the same ``reason`` in both, and no
traceback. Writes benchmarks/results/dynamics_stiffness.{md,json} (a sweep of some problems or
variants replaces their rows and keeps the others'); docs/benchmarks.md's dynamics table is its
summary. ``--quick``: stiffness 1e2, 1e5, 1e8 only. tests/dynamics/
test_stiffness_sweep.py runs the grid reduced (two turns, rtol 1e-6, each corner on one of
the two methods).
"""
from __future__ import annotations

import argparse
import itertools
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

PROBLEMS = {"fourbar": ROOT / "problems" / "sharkov2022_dynamics.yaml",
            "reducer": ROOT / "problems" / "pulse_reducer_dynamics.yaml"}
VARIANTS = {"ratchet": [], "composite": ["--freewheel", "composite"],
            "constant crank": ["--crank", "constant"]}
RESULTS = ROOT / "benchmarks" / "results"


# ------------------------------------------------------------------ methods
def problem(stiffness: float, inertia: float, damping: float, turns: int):
    from optdesign.problem.loader import problem_from_dict

    data = yaml.safe_load((ROOT / "problems" / "sharkov2022.yaml").read_text())
    data["dynamics"] = dict(I1=0.014, I2=inertia, stiffness=stiffness, damping_ratio=damping,
                            motor={"a": 230.0, "b": 2.35}, load=20.0, cycles=turns,
                            steady_tol=1e-12)
    return problem_from_dict(data, "benchmark.yaml")


def run_meta(**extra) -> dict:
    """This run's machine, time and command: the 'measured on' line of benchmarks/docs.py."""
    return {"python": sys.version.split()[0], "time": time.strftime("%Y-%m-%d %H:%M:%S"),
            "machine": f"{platform.machine()} {platform.system()}", "cores": os.cpu_count(),
            "command": "PYTHONPATH=. python benchmarks/dynamics_stiffness.py " +
                       " ".join(sys.argv[1:])} | extra


def compare_methods(args) -> None:
    """One row per (stiffness, method), printed as it comes, then written to
    benchmarks/results/NAME.{md,json} (NAME from ``--name``): table 1 every row, table 2 the
    docs/benchmarks.md's columns (Radau against RK45)."""
    from optdesign.dynamics.steady import simulate
    from optdesign.outputs.atomic import atomic_write_json, atomic_write_text

    conditions = (f"four-bar converter, I2 = {args.inertia:g} kg·m², damping ratio "
                  f"{args.damping:g}, {args.turns} turns from the same start, rtol 1e-8, "
                  f"atol 1e-10 rad")
    print(conditions)
    head = (f"{'λ N·m/rad':>10} {'√(λ/I2) 1/s':>12} {'method':>6} {'steps':>8} {'nfev':>9} "
            f"{'njev':>6} {'nlu':>7} {'switches':>8} {'time s':>8} {'δ dynamic':>10}")
    print(head)
    print("-" * len(head))
    rows = []
    for stiffness in (float(s) for s in args.stiffness.split(",")):
        for method in args.methods.split(","):
            p = problem(stiffness, args.inertia, args.damping, args.turns)
            clock = time.perf_counter()
            r = simulate(p, method=method)
            wall = time.perf_counter() - clock
            c = r.counters
            rows.append({"stiffness": stiffness, "omega_stiff": (stiffness / args.inertia) ** 0.5,
                         "method": method, "steps": r.steps, "nfev": c["nfev"],
                         "njev": c["njev"], "nlu": c["nlu"], "switches": r.events,
                         "time_s": wall, "delta_dynamic": r.dynamic.delta})
            print(f"{stiffness:>10.0e} {(stiffness / args.inertia) ** 0.5:>12.3g} "
                  f"{method:>6} {r.steps:>8d} {c['nfev']:>9d} {c['njev']:>6d} {c['nlu']:>7d} "
                  f"{r.events:>8d} {wall:>8.2f} {r.dynamic.delta:>10.6f}", flush=True)
    atomic_write_json(RESULTS / f"{args.name}.json",
                      {"meta": run_meta(conditions=conditions), "rows": rows})
    atomic_write_text(RESULTS / f"{args.name}.md", methods_report(rows, conditions))
    print(f"wrote {RESULTS / (args.name + '.md')}")


def methods_report(rows: list[dict], conditions: str) -> str:
    """Table 1: every (stiffness, method); table 2: Radau against RK45 per stiffness."""
    lines = [f"Explicit against implicit: {conditions}; one run on a shared machine, wall "
             "times with other jobs running.", "",
             "| λ [N·m/rad] | √(λ/I2) [1/s] | method | steps | nfev | njev | nlu | switches | "
             "time [s] | δ dynamic |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['stiffness']:.0e} | {r['omega_stiff']:.3g} | {r['method']} | "
                     f"{r['steps']} | {r['nfev']} | {r['njev']} | {r['nlu']} | {r['switches']} | "
                     f"{r['time_s']:.2f} | {r['delta_dynamic']:.6f} |")
    by = {(r["stiffness"], r["method"]): r for r in rows}
    pairs = [s for s in dict.fromkeys(r["stiffness"] for r in rows)
             if (s, "Radau") in by and (s, "RK45") in by]
    if pairs:
        lines += ["", "Radau against RK45:", "",
                  "| λ [N·m/rad] | Radau steps | Radau time [s] | RK45 steps | RK45 time [s] | "
                  "δ dynamic |", "|---|---|---|---|---|---|"]
        for s in pairs:
            a, b = by[(s, "Radau")], by[(s, "RK45")]
            lines.append(f"| {s:.0e} | {a['steps']} | {a['time_s']:.2f} | {b['steps']} | "
                         f"{b['time_s']:.2f} | {a['delta_dynamic']:.4f} |")
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------------ sweep
def sweep_cases(stiffnesses, problems=tuple(PROBLEMS), variants=tuple(VARIANTS)):
    for name, variant, method, stiffness, damping in itertools.product(
            problems, variants, ("Radau", "BDF"), stiffnesses, (0.0, 0.1)):
        yield {"problem": name, "variant": variant, "method": method,
               "stiffness": stiffness, "damping_ratio": damping}


def _refuse(constant):
    raise ValueError(f"not JSON: {constant}")


def run_case(case: dict, folder: Path, timeout: float) -> dict:
    """One ``optdesign simulate --json`` in its own process; what it ended in."""
    data = yaml.safe_load(PROBLEMS[case["problem"]].read_text())
    data["dynamics"].update(stiffness=case["stiffness"], damping_ratio=case["damping_ratio"])
    tag = "_".join(str(v).replace(" ", "-") for v in case.values())
    path = folder / f"{tag}.yaml"
    path.write_text(yaml.safe_dump(data))
    command = [sys.executable, "-m", "optdesign", "simulate", str(path), "--json",
               "--method", case["method"], "--out", str(folder / tag), *VARIANTS[case["variant"]]]
    clock = time.perf_counter()
    try:
        done = subprocess.run(command, capture_output=True, text=True, cwd=ROOT,
                              timeout=timeout, env=os.environ | {"PYTHONPATH": str(ROOT)})
    except subprocess.TimeoutExpired:
        return case | {"exit": None, "passed": False, "wall_s": timeout,
                       "reason": f"no answer within {timeout:g} s"}
    wall = time.perf_counter() - clock
    err = done.stderr.strip().splitlines()
    try:
        result = json.loads(done.stdout, parse_constant=_refuse)
    except ValueError:
        result = {}
    passed = ("Traceback" not in done.stderr and bool(result)
              and (done.returncode == 0 and not err and result.get("status") == "steady"
                   or done.returncode == 1 and len(err) == 1
                   and err[0].endswith(str(result.get("reason")))))
    return case | {"exit": done.returncode, "passed": passed, "wall_s": round(wall, 2),
                   "status": result.get("status"), "turns": result.get("cycles"),
                   "period_turns": result.get("period_turns"),
                   "delta_dynamic": result.get("delta_dynamic"),
                   "omega_out_mean": result.get("omega_out_mean"),
                   "steps": result.get("steps"),
                   "reason": result.get("reason") or (err[-1] if err else None)}


def sweep(args) -> None:
    stiffnesses = [1e2, 1e5, 1e8] if args.quick else [10.0 ** k for k in range(2, 9)]
    cases = list(sweep_cases(stiffnesses, args.problems.split(","), args.variants.split(",")))
    rows = []
    with tempfile.TemporaryDirectory() as tmp, ThreadPoolExecutor(args.jobs) as pool:
        for row in pool.map(lambda c: run_case(c, Path(tmp), args.timeout), cases):
            rows.append(row)
            print(f"{row['problem']:8} {row['variant']:14} {row['method']:5} "
                  f"{row['stiffness']:7.0e} ζ={row['damping_ratio']:<4g} exit {row['exit']} "
                  f"{row.get('status')!s:10} {row['wall_s']:7.1f} s "
                  f"{'' if row['passed'] else 'FAILED'}", flush=True)
    from optdesign.outputs.atomic import atomic_write_json, atomic_write_text

    name = "dynamics_stiffness_quick" if args.quick else "dynamics_stiffness"
    rows = _merged(RESULTS / f"{name}.json", rows, stiffnesses)
    # the time is that of this run, though rows of earlier runs may be kept (``_merged``)
    atomic_write_json(RESULTS / f"{name}.json", {"meta": run_meta(), "cases": rows})
    atomic_write_text(RESULTS / f"{name}.md", sweep_report(rows))
    print(f"wrote {RESULTS / name}.md, .json; {sum(r['passed'] for r in rows)} of "
          f"{len(rows)} runs passed")


def _merged(path: Path, rows: list[dict], stiffnesses) -> list[dict]:
    """``rows`` in place of the same cases of an earlier run in ``path`` (a sweep of some
    problems or variants refreshes those), in the order of the whole grid."""
    def key(row):
        return tuple(row[k] for k in ("problem", "variant", "method", "stiffness",
                                      "damping_ratio"))

    known = {key(r): r for r in json.loads(path.read_text())["cases"]} if path.exists() else {}
    known.update({key(r): r for r in rows})
    order = [key(c) for c in sweep_cases(stiffnesses)]
    return [known[k] for k in order if k in known]


def sweep_report(rows: list[dict]) -> str:
    """The summary table (one row per problem and variant) and every run."""
    lines = ["`optdesign simulate` over its promised range, each run the real command in its "
             "own process at the problem file's settings (100 turns at most, rtol 1e-8); "
             "stiffness 1e2 … 1e8 N·m/rad × damping ratio {0, 0.1} × {Radau, BDF}. Passed: "
             "exit 0 and steady, or exit 1 with one line on stderr and the same reason in the "
             "strict JSON; never a traceback.", "",
             "| problem | variant | runs | passed | steady | not steady | stalled | failed "
             "| longest [s] |", "|---|---|---|---|---|---|---|---|---|"]
    for (name, variant), group in itertools.groupby(
            rows, key=lambda r: (r["problem"], r["variant"])):
        group = list(group)
        count = {s: sum(r.get("status") == s for r in group)
                 for s in ("steady", "not_steady", "stalled", "failed")}
        lines.append(f"| {name} | {variant} | {len(group)} | "
                     f"{sum(r['passed'] for r in group)} | {count['steady']} | "
                     f"{count['not_steady']} | {count['stalled']} | {count['failed']} | "
                     f"{max(r['wall_s'] for r in group):.0f} |")
    lines += ["", "Every run:", "",
              "| problem | variant | method | λ [N·m/rad] | ζ | exit | status | turns | period "
              "| δ dynamic | time [s] | reason |", "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        delta = "–" if r.get("delta_dynamic") is None else f"{r['delta_dynamic']:.4f}"
        lines.append(f"| {r['problem']} | {r['variant']} | {r['method']} | "
                     f"{r['stiffness']:.0e} | {r['damping_ratio']:g} | {r['exit']} | "
                     f"{r.get('status') or '–'} | {r.get('turns') or '–'} | "
                     f"{r.get('period_turns') or '–'} | {delta} | {r['wall_s']:.1f} | "
                     f"{(r.get('reason') or '').replace('|', '/')} |")
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sweep", action="store_true", help="the command over its whole range")
    ap.add_argument("--quick", action="store_true", help="sweep: stiffness 1e2, 1e5, 1e8")
    ap.add_argument("--jobs", type=int, default=1, help="sweep: runs at once")
    ap.add_argument("--problems", default=",".join(PROBLEMS),
                    help="sweep: these problems only (the others' rows are kept)")
    ap.add_argument("--variants", default=",".join(VARIANTS),
                    help="sweep: these variants only (the others' rows are kept)")
    ap.add_argument("--timeout", type=float, default=1800.0, help="sweep: seconds a run")
    ap.add_argument("--turns", type=int, default=2)
    ap.add_argument("--inertia", type=float, default=1e-4, help="I2, kg·m²")
    ap.add_argument("--damping", type=float, default=0.1, help="freewheel damping ratio ζ")
    ap.add_argument("--methods", default="Radau,BDF,RK45")
    ap.add_argument("--stiffness", default="1e2,1e3,1e4,1e5,1e6,1e7")
    ap.add_argument("--name", default="dynamics_methods",
                    help="methods: results file benchmarks/results/NAME.{md,json}")
    args = ap.parse_args()
    sweep(args) if args.sweep else compare_methods(args)


if __name__ == "__main__":
    main()

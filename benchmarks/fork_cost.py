"""What a fork costs the process that forks: one IPOPT run of a warm NLP alone, and right
after a fork whose child only sleeps (the pages the run writes, shared with the child, are
copied as it first writes them; the minor page faults count them). The reason a solve keeps
the child its polishes beside run in (optdesign/kept_children.py) instead of forking one
for each. Writes benchmarks/results/fork_cost.md and .json.

    python benchmarks/fork_cost.py [--cases disc_n6 disc_n24] [--repeats 5]
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from optdesign.outputs.atomic import atomic_write_text  # noqa: E402


def run_of(problem):
    """A function that runs IPOPT once from the winning start of ``problem``'s answer on its
    NLP, built beforehand: (seconds, minor page faults) of the run."""
    from solve_floor import answer_phase, winning_start

    from optdesign.evaluation.figures import forget
    from optdesign.solver.driver import solve
    from optdesign.solver.phase_solver import PhaseSolver

    result = solve(problem)
    forget()
    count, start, _ = winning_start(problem, answer_phase(problem, result))
    solver = PhaseSolver(problem, count)
    hessian = problem.solver.hessian
    ver = solver.verify(problem, start, search=False)
    solver.nlp(ver.sequences).solver(hessian)

    def run() -> tuple[float, int]:
        faults = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
        t0 = time.perf_counter()
        solver._ipopt(problem, ver, 0.0, hessian)
        return (time.perf_counter() - t0,
                resource.getrusage(resource.RUSAGE_SELF).ru_minflt - faults)
    run()
    return run


def after_a_fork(run) -> tuple[float, int]:
    """``run()`` right after forking a child that sleeps until it is ended."""
    pid = os.fork()
    if pid == 0:
        time.sleep(60)
        os._exit(0)
    try:
        return run()
    finally:
        os.kill(pid, 9)
        os.waitpid(pid, 0)


def measure(case: str, repeats: int) -> dict:
    from solve_vs_peers import load_case

    run = run_of(load_case(case))
    alone, forked = [], []
    for _ in range(repeats):            # alternating
        alone.append(run())
        forked.append(after_a_fork(run))
    return {"case": case,
            "alone_s": statistics.median(t for t, _ in alone),
            "alone_faults": statistics.median(f for _, f in alone),
            "after_fork_s": statistics.median(t for t, _ in forked),
            "after_fork_faults": statistics.median(f for _, f in forked)}


def table(rows: list[dict], meta: dict) -> str:
    lines = ["One IPOPT run of a warm NLP from the answer's winning start, alone and right "
             "after a fork whose child sleeps (medians, alternating; minor page faults of "
             "the run).", "",
             "| problem | alone [ms] | after a fork [ms] | after / alone | page faults alone "
             "| page faults after a fork |", "|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['case']} | {1e3 * r['alone_s']:.1f} | {1e3 * r['after_fork_s']:.1f} "
                     f"| {r['after_fork_s'] / r['alone_s']:.2f} | {r['alone_faults']:.0f} "
                     f"| {r['after_fork_faults']:.0f} |")
    lines += ["", f"measured on {meta['machine']}, {meta['cores']} cores, {meta['time']} "
              f"(Python {meta['python']})"]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", nargs="+", default=["disc_n6", "disc_n24"])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args(argv)
    rows = [measure(case, max(1, min(args.repeats, 50))) for case in args.cases]
    meta = {"machine": f"{platform.machine()} {platform.system()}", "cores": os.cpu_count(),
            "time": time.strftime("%Y-%m-%d %H:%M:%S"), "python": platform.python_version()}
    RESULTS.mkdir(parents=True, exist_ok=True)
    atomic_write_text(RESULTS / "fork_cost.md", table(rows, meta))
    atomic_write_text(RESULTS / "fork_cost.json", json.dumps({"meta": meta, "results": rows},
                                                              indent=1))
    print(table(rows, meta))
    return 0


if __name__ == "__main__":
    sys.exit(main())

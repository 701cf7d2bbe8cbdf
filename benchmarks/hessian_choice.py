"""Exact Hessian (CasADi's second derivatives) against IPOPT's limited-memory quasi-Newton one.

Runs the same problems back to back with both settings and prints exact δ, ratio, IPOPT
iterations, starts used and in-process time; the README records one run and the default it
justifies (``solver: {hessian: ...}``).

    python benchmarks/hessian_choice.py
"""
from __future__ import annotations

import sys
import time
from dataclasses import replace
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from optdesign.problem.loader import problem_from_dict  # noqa: E402
from optdesign.solver import solve  # noqa: E402


def variants():
    base = yaml.safe_load((ROOT / "problems" / "sharkov2022_disc.yaml").read_text())
    yield "disc, n = 6", base
    yield "disc, n in {4, 8}", base | {"design": base["design"] | {"phases": {"choices": [4, 8]}}}
    yield "disc, e in {1, 0.5}", base | {"regulation": {"eccentricity": [1.0, 0.5]}}
    yield "disc, max ratio, δ <= 0.2", base | {"objective": {"minimize": "-ratio",
                                                            "max_ripple": 0.2}}


def main() -> int:
    print("| problem | hessian | exact δ | ratio | iterations | starts | time [s] |")
    print("|---|---|---|---|---|---|---|")
    for name, data in variants():
        problem = problem_from_dict(data, where=name)
        for hessian in ("exact", "limited-memory"):
            p = replace(problem, solver=replace(problem.solver, hessian=hessian))
            t0 = time.perf_counter()
            r = solve(p)
            elapsed = time.perf_counter() - t0
            starts = sum(len(ph.starts) for ph in r.per_phase)
            delta = f"{r.delta:.6f}" if r.delta is not None else r.status
            ratio = f"{r.ratio:.4f}" if r.ratio is not None else "-"
            print(f"| {name} | {hessian} | {delta} | {ratio} | {r.iterations} | {starts} | "
                  f"{elapsed:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())

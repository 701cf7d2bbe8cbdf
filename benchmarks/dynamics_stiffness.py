"""Explicit against implicit integration of the drive over the freewheel stiffness.

    PYTHONPATH=. python benchmarks/dynamics_stiffness.py [--turns 2] [--inertia 1e-4]
        [--damping 0.1] [--methods Radau,BDF,RK45] [--stiffness 1e2,1e3,...]

Sharkov & Kalinin's six-phase four-bar converter (problems/sharkov2022.yaml) with the pulse
reducer paper's motor and input inertia, a light output (I2) and a 20 N·m load, simulated for a
fixed number of crank turns from the same start with each method at rtol 1e-8, atol 1e-10 rad.
Prints one row per (stiffness, method): accepted steps, right-hand-side evaluations, Jacobians,
LU factorisations, switches (engagements + releases), wall time, and the dynamic δ of the last
turn (the methods must agree on it). The table of one run is recorded in docs/dynamics.md.
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]


def problem(stiffness: float, inertia: float, damping: float, turns: int):
    from optdesign.problem import problem_from_dict

    data = yaml.safe_load((ROOT / "problems" / "sharkov2022.yaml").read_text())
    data["dynamics"] = dict(I1=0.014, I2=inertia, stiffness=stiffness, damping_ratio=damping,
                            motor={"a": 230.0, "b": 2.35}, load=20.0, cycles=turns,
                            steady_tol=1e-12)
    return problem_from_dict(data, "benchmark.yaml")


def main() -> None:
    from optdesign.dynamics.steady import simulate

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--turns", type=int, default=2)
    ap.add_argument("--inertia", type=float, default=1e-4, help="I2, kg·m²")
    ap.add_argument("--damping", type=float, default=0.1, help="freewheel damping ratio ζ")
    ap.add_argument("--methods", default="Radau,BDF,RK45")
    ap.add_argument("--stiffness", default="1e2,1e3,1e4,1e5,1e6,1e7")
    args = ap.parse_args()
    print(f"four-bar converter, I2 = {args.inertia:g} kg·m², ζ = {args.damping:g}, "
          f"{args.turns} turns, rtol 1e-8, atol 1e-10 rad")
    head = (f"{'λ N·m/rad':>10} {'√(λ/I2) 1/s':>12} {'method':>6} {'steps':>8} {'nfev':>9} "
            f"{'njev':>6} {'nlu':>7} {'switches':>8} {'time s':>8} {'δ dynamic':>10}")
    print(head)
    print("-" * len(head))
    for stiffness in (float(s) for s in args.stiffness.split(",")):
        for method in args.methods.split(","):
            p = problem(stiffness, args.inertia, args.damping, args.turns)
            clock = time.perf_counter()
            r = simulate(p, method=method)
            wall = time.perf_counter() - clock
            c = r.counters
            print(f"{stiffness:>10.0e} {(stiffness / args.inertia) ** 0.5:>12.3g} "
                  f"{method:>6} {r.steps:>8d} {c['nfev']:>9d} {c['njev']:>6d} {c['nlu']:>7d} "
                  f"{r.events:>8d} {wall:>8.2f} {r.dynamic.delta:>10.6f}", flush=True)


if __name__ == "__main__":
    main()

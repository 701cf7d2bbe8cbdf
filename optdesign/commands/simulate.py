"""``optdesign simulate PROBLEM.yaml [--json] [--out DIR]``: the drive's steady cycle.

Needs a ``dynamics:`` section (:mod:`optdesign.dynamics.section`). Writes DIR/dynamics.json,
DIR/dynamics_cycle.csv and the figures DIR/dynamics_angles.png (the paper's Fig. 2) and
DIR/dynamics_speeds.png (Fig. 3), all atomically; default DIR is results/NAME/. Exit 0 when the
cycle repeated, 1 when ``cycles`` ran out first (the last turn is still reported and written).
"""
from __future__ import annotations

import json
from pathlib import Path


def add_parser(sub) -> None:
    p = sub.add_parser("simulate", help="simulate the drive with compliant freewheels to its "
                                        "steady cycle (needs a dynamics: section)")
    p.add_argument("problem", help="problem file (YAML) with a dynamics: section")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--out", help="output directory (default results/NAME/)")
    p.add_argument("--method", choices=("Radau", "BDF", "LSODA", "RK45"),
                   help="override dynamics.method (RK45: explicit, for comparison only)")
    p.add_argument("--freewheel", choices=("ratchet", "composite"),
                   help="override dynamics.freewheel")
    p.add_argument("--crank", choices=("dynamic", "constant"), help="override dynamics.crank")
    p.add_argument("--cycles", type=int, help="override dynamics.cycles (most turns)")
    p.set_defaults(run=run)


def run(args) -> int:
    from dataclasses import replace

    from ..dynamics.steady import simulate
    from ..outputs import write_simulation
    from ..errors import ProblemError
    from ..problem import load_problem

    problem = load_problem(args.problem)
    section = problem.require_section("dynamics")
    overrides = {k: getattr(args, k) for k in ("freewheel", "crank", "cycles")
                 if getattr(args, k) is not None}
    if overrides.get("cycles", 1) < 1:
        raise ProblemError(f"--cycles must be at least 1 (got {overrides['cycles']})")
    result = simulate(problem, replace(section, **overrides), method=args.method)
    out = Path(args.out) if args.out else Path("results") / problem.name
    write_simulation(result, out)
    if args.json:
        print(json.dumps(result.to_dict(), indent=2))
    else:
        print(format_result(result))
        print(f"wrote {out}/dynamics.json, dynamics_cycle.csv, dynamics_angles.png, "
              f"dynamics_speeds.png")
    return 0 if result.steady else 1


def format_result(r) -> str:
    inst, first = r.instants, r.first_turn

    def ms(x):
        return "-" if x is None else f"{1e3 * x:.2f} ms"

    lines = [
        f"{r.name}: {r.mechanism}, {r.freewheel} freewheels, {r.crank} crank, {r.method} "
        f"(rtol {r.rtol:g}, atol {r.atol:g} rad)"
        + (" - explicit, for comparison only" if r.method == "RK45" else ""),
        f"  {'steady' if r.steady else 'NOT steady'} after {r.cycles} turns "
        f"(residual {r.steady_residual:.2g}); {r.steps} steps, {r.events} switches, "
        f"{r.wall_time_s:.2f} s",
        f"  cycle time       {r.cycle_time_s:.6f} s",
        f"  input speed      {r.omega_in_mean:.4f} rad/s (mean)",
        f"  output speed     {r.omega_out_mean:.4f} rad/s (mean), "
        f"{r.dynamic.omega_min:.4f} .. {r.dynamic.omega_max:.4f}",
        f"  ripple δ         {r.dynamic.delta:.4f} dynamic, {r.kinematic.delta:.4f} kinematic "
        f"(midrange); {r.dynamic.delta_mean:.4f}, {r.kinematic.delta_mean:.4f} (time mean)",
        f"  eps_max          {r.eps_max:.5g} rad",
        f"  power            {r.power_in_w:.4f} W in, {r.power_out_w:.4f} W out "
        f"(balance {r.power_balance:.2e})",
        f"  steady cycle     freewheel {inst.get('freewheel', '-')} closes, "
        f"t1 {ms(inst.get('t1_s'))} (ε max), t2 {ms(inst.get('t2_s'))} (release), t3 {ms(inst.get('t3_s'))} (next closes)",
        f"  first turn       t1 {ms(first.get('t1_s'))}, t2 {ms(first.get('t2_s'))}, "
        f"t3 {ms(first.get('t3_s'))}, ε max {first.get('eps_max') or 0:.5g} rad",
    ]
    return "\n".join(lines)

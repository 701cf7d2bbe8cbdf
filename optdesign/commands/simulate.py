"""``optdesign simulate PROBLEM.yaml [--json] [--out DIR] [--design FILE [--point K |
--knee]]``: the drive's steady cycle.

Needs a ``dynamics:`` section (:mod:`optdesign.dynamics.section`). Writes DIR/dynamics.json,
DIR/dynamics_cycle.csv and the figures DIR/dynamics_angles.png (the paper's Fig. 2),
DIR/dynamics_speeds.png (Fig. 3) and DIR/dynamics_loads.png (freewheel torques, joint forces),
all atomically; default DIR is results/NAME/. Exit 0 when the
cycle repeated; 1 when ``cycles`` ran out first, the output stalls or the integration fails,
with the reason in one line on stderr and in the JSON's ``reason`` (the last turn is still
reported and written; a failed integration writes dynamics.json alone).
"""
from __future__ import annotations

import sys

from optdesign.commands.design_source import add_arguments, loaded
from optdesign.outputs.phases import phase


def add_parser(sub) -> None:
    p = sub.add_parser("simulate", help="simulate the drive with compliant freewheels to its "
                                        "steady cycle (needs a dynamics: section)")
    p.add_argument("problem", help="problem file (YAML) with a dynamics: section")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--out", help="output directory (default results/NAME/)")
    p.add_argument("--force", action="store_true",
                   help="replace results of another problem file in the output folder")
    p.add_argument("--method", choices=("Radau", "BDF", "LSODA", "RK45"),
                   help="override dynamics.method (RK45: explicit, for comparison only)")
    p.add_argument("--freewheel", choices=("ratchet", "composite"),
                   help="override dynamics.freewheel")
    p.add_argument("--crank", choices=("dynamic", "constant"), help="override dynamics.crank")
    p.add_argument("--cycles", type=int, help="override dynamics.cycles (most turns)")
    add_arguments(p)
    p.set_defaults(run=run)


def run(args) -> int:
    with phase("imports"):
        from dataclasses import replace

        from optdesign.dynamics.section import MAX_CYCLES
        from optdesign.errors import SolveError, UsageError
        from optdesign.figures.design import warm_up
        from optdesign.outputs.answer import print_answer, raise_if_unprinted
        from optdesign.outputs.atomic import json_text
        from optdesign.outputs.checks import prepare_out
        from optdesign.outputs.figure_process import FigureProcess
        from optdesign.outputs.folder import write_set
        from optdesign.problem.loader import load_problem  # noqa: F401  (read by loaded())
        from optdesign.commands.files import draw_simulation, write_simulation

    with phase("reading"):
        problem, chosen = loaded(args, one_count=False)
        section = problem.require_section("dynamics")
    overrides = {k: getattr(args, k) for k in ("freewheel", "crank", "cycles")
                 if getattr(args, k) is not None}
    if overrides.get("cycles", 1) < 1:
        raise UsageError(f"--cycles must be at least 1 (got {overrides['cycles']})")
    if overrides.get("cycles", 1) > MAX_CYCLES:
        raise UsageError(f"--cycles must be at most {MAX_CYCLES} (got {overrides['cycles']})")
    out = prepare_out(args.out, problem.name, files=SIMULATE_FILES, source=args.problem,
                      force=args.force)
    section = replace(section, **overrides)
    from optdesign.dynamics.section import check_motor_speed

    check_motor_speed(section, problem)          # before any work: exit 2 naming both
    # the figures' process imports matplotlib while this one integrates
    with FigureProcess(warm=warm_up) as figures:
        with phase("imports"):
            from tqdm import tqdm

            from optdesign.dynamics.steady import simulate
        try:            # turns until the cycle repeats: the bar ends early when it does
            with phase("solving"), tqdm(total=section.cycles, desc="turns", unit="turn",
                                        file=sys.stderr, disable=None, leave=False) as bar:
                result = simulate(problem, section, method=args.method, progress=bar.update)
        except SolveError as exc:
            return _failed(problem, section, args, out, exc)

        def write(into):
            with phase("files"):
                written = write_simulation(result, into, plots=False)
                print_answer(json_text(chosen.stamped(result.to_dict())) if args.json else
                             f"{chosen.line(problem)}\n{format_result(result)}")
            with phase("figures"):
                return written + draw_simulation(result, into, figures)
        write_set(out, SIMULATE_FILES, write)      # the earlier set, or this one whole
    raise_if_unprinted()
    if not args.json:
        print(f"wrote {out}/dynamics.json, dynamics_cycle.csv, dynamics_angles.png, "
              f"dynamics_speeds.png, dynamics_loads.png, dynamics_frequencies.png")
    if result.steady:
        return 0
    print(f"optdesign: {problem.source}: {result.reason}", file=sys.stderr)
    return 1


def _failed(problem, section, args, out, exc) -> int:
    """An integration that stopped before a cycle: dynamics.json holds status and reason."""
    from optdesign.dynamics.integrator import StallError
    from optdesign.dynamics.result import failure_dict
    from optdesign.outputs.atomic import atomic_write_json, json_text
    from optdesign.outputs.folder import write_set

    data = failure_dict(problem, section, args.method or section.method,
                        "stalled" if isinstance(exc, StallError) else "failed", str(exc))
    # its set is dynamics.json alone: no cycle or figure of an earlier run stays beside it
    write_set(out, SIMULATE_FILES, lambda into: [atomic_write_json(into / "dynamics.json",
                                                                   data)])
    if args.json:
        print(json_text(data))
    print(f"optdesign: {problem.source}: {exc}", file=sys.stderr)
    return 1


#: the files of a simulation, replaced together
SIMULATE_FILES = ("dynamics.json", "dynamics_cycle.csv", "dynamics_angles.png",
                  "dynamics_speeds.png", "dynamics_loads.png", "dynamics_frequencies.png")
STATUS_TEXT = {"steady": "steady", "not_steady": "NOT steady", "stalled": "STALLED"}


def format_result(r) -> str:
    inst, first = r.instants, r.first_turn

    def ms(x):
        return "-" if x is None else f"{1e3 * x:.2f} ms"

    lines = [
        f"{r.name}: {r.mechanism}, {r.freewheel} freewheels, {r.crank} crank, {r.method} "
        f"(rtol {r.rtol:g}, atol {r.atol:g} rad)"
        + (" - explicit, for comparison only" if r.method == "RK45" else ""),
        f"  {STATUS_TEXT.get(r.status, r.status)} after {r.cycles} turns "
        f"(residual {r.steady_residual:.2g}); {r.steps} steps, {r.events} switches, "
        f"{r.wall_time_s:.2f} s" + (f"\n  reason           {r.reason}" if r.reason else ""),
        f"  cycle time       {r.cycle_time_s:.6f} s"
        + (f" (the motion repeats every {r.period_turns} turns, {r.period_s:.6f} s)"
           if r.period_turns > 1 else ""),
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
        f"  first turn       freewheel {first.get('freewheel') or '-'} closes at "
        f"{ms(first.get('t0_s'))}, t1 {ms(first.get('t1_s'))}, t2 {ms(first.get('t2_s'))}, "
        f"t3 {ms(first.get('t3_s'))}, ε max {first.get('eps_max') or 0:.5g} rad",
    ]
    from optdesign.dynamics.resonance import resonance_text

    lines += resonance_text(r.resonance, r.dynamic.delta, r.kinematic.delta) \
        if r.resonance else []
    return "\n".join(lines + load_lines(r.loads))


def load_lines(loads: dict) -> list[str]:
    """The loads of the steady cycle: each freewheel's peak torque and engagement share,
    the crank's peak torque, each joint's peak force."""
    if not loads:
        return []
    wheels = loads["freewheels"]
    engaged = [w for w in wheels if w["engaged_share"] > 0]
    lines = [f"  freewheels       {len(engaged)} of {len(wheels)} engage over the cycle; mean "
             f"total torque {loads['mean_freewheel_torque_n_m']:.4g} N·m; crank's peak "
             f"{loads['peak_crank_torque_n_m']:.4g} N·m"]
    lines += [f"    {w['freewheel']:>4}  peak {w['peak_torque_n_m']:9.4g} N·m at φ = "
              f"{w['peak_at_phi_deg']:6.1f}°, engaged {100 * w['engaged_share']:5.1f} % of the "
              f"cycle" for w in wheels]
    if loads.get("joints"):
        lines.append("  joint forces     peak over the cycle, links massless:")
        lines += [f"    {j['joint']:>4}  {j['kind']:<5} {j['peak_force_n']:10.5g} N at φ = "
                  f"{j['peak_at_phi_deg']:6.1f}°" for j in loads["joints"]]
    elif loads.get("joints_note"):
        lines.append(f"  joint forces     none: {loads['joints_note']}")
    return lines

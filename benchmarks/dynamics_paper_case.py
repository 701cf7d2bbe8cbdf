"""The pulse reducer paper's dynamic case through the command: the tables of docs/dynamics.md.

    python benchmarks/dynamics_paper_case.py      # about 15 s

Runs ``optdesign simulate problems/pulse_reducer_dynamics.yaml --json`` three times in its own
processes (the steady cycle; ``--cycles 1``, the first turn; ``--freewheel composite --crank
constant --cycles 1``; these two end in exit 1, "not steady", with their first turn's
figures) and writes benchmarks/results/dynamics_paper_case.{md,json}: table 1 the
paper's instants and ε_max beside ours, table 2 the steady cycle's figures. The paper's values
are those of its text and Figs. 2–3 (docs/papers.md); the load T_c = 13 N·m is our choice
(docs/dynamics.md).
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

PROBLEM = ROOT / "problems" / "pulse_reducer_dynamics.yaml"
RESULTS = ROOT / "benchmarks" / "results"
RUNS = {"steady": [], "first_turn": ["--cycles", "1"],
        "composite_constant": ["--freewheel", "composite", "--crank", "constant",
                               "--cycles", "1"]}
#: the paper's figures: cycle time t_c [s], instants t1, t2, t3 [ms], ε_max [rad]
PAPER = {"t_c": 0.065, "t1": 14, "t2": 21, "t3": 38, "eps_max": 0.012}


def run(flags: list[str]) -> dict:
    """One ``optdesign simulate --json`` in its own process: its strict JSON."""
    with tempfile.TemporaryDirectory() as folder:
        out = subprocess.run([sys.executable, "-m", "optdesign", "simulate", str(PROBLEM),
                              "--json", "--out", folder, *flags], capture_output=True,
                             text=True, cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)})
    if out.returncode not in (0, 1) or not out.stdout.strip():   # 1: not steady in --cycles
        raise SystemExit(f"simulate {' '.join(flags)} ended in {out.returncode}: {out.stderr}")
    return json.loads(out.stdout)


def _first(r: dict) -> dict:
    """The first turn's figures in the table's units (s, ms, rad)."""
    f = r["first_turn"]
    return {"t_c": f"{r['cycle_time_s']:.5f}", "t1": f"{f['t1_s'] * 1e3:.2f}",
            "t2": f"{f['t2_s'] * 1e3:.2f}", "t3": f"{f['t3_s'] * 1e3:.2f}",
            "eps_max": f"{f['eps_max']:.5f}"}


def _steady(r: dict) -> dict:
    i = r["instants"]
    return {"t_c": f"{r['period_s']:.6f}", "t1": f"{i['t1_s'] * 1e3:.2f}",
            "t2": f"{i['t2_s'] * 1e3:.2f}", "t3": f"{i['t3_s'] * 1e3:.2f}",
            "eps_max": f"{r['eps_max']:.5f}"}


def report(runs: dict) -> str:
    first, steady, comp = _first(runs["first_turn"]), _steady(runs["steady"]), \
        _first(runs["composite_constant"])
    names = {"t_c": "t_c, s", "t1": "t1 (end of jamming, ε max), ms",
             "t2": "t2 (release, start of overrun), ms", "t3": "t3 (next freewheel closes), ms",
             "eps_max": "ε_max, rad"}
    lines = ["`optdesign simulate problems/pulse_reducer_dynamics.yaml` (ratchet, dynamic crank, "
             "Radau); first turn `--cycles 1`, last column `--freewheel composite --crank "
             "constant --cycles 1`.", "",
             "| figure | paper | ours, first turn | ours, steady cycle | composite, constant "
             "crank, first turn |", "|---|---|---|---|---|"]
    for key, name in names.items():
        lines.append(f"| {name} | {PAPER[key]:g} | {first[key]} | {steady[key]} | {comp[key]} |")
    s = runs["steady"]
    lines += ["", "The steady cycle:", "", "| figure | value |", "|---|---|",
              f"| turns to steady (residual) | {s['cycles']} ({s['steady_residual']:.1e}) |",
              f"| steps, switches | {s['steps']}, {s['events']} |",
              f"| crank mean speed, rad/s | {s['omega_in_mean']:.3f} |",
              f"| output speed mean (min .. max), rad/s | {s['omega_out_mean']:.3f} "
              f"({s['omega_out_min']:.3f} .. {s['omega_out_max']:.3f}) |",
              f"| δ dynamic, midrange (time mean) | {s['delta_dynamic']:.3f} "
              f"({s['delta_mean_dynamic']:.3f}) |",
              f"| δ kinematic, midrange (time mean) | {s['delta_kinematic']:.3f} "
              f"({s['delta_mean_kinematic']:.3f}) |",
              f"| power in, out, W (balance) | {s['power_in_w']:.3f}, {s['power_out_w']:.3f} "
              f"({s['power_balance']:.0e}) |"]
    return "\n".join(lines) + "\n"


def main() -> int:
    from optdesign.outputs.atomic import atomic_write_json, atomic_write_text

    runs = {name: run(flags) for name, flags in RUNS.items()}
    meta = {"python": sys.version.split()[0], "time": time.strftime("%Y-%m-%d %H:%M:%S"),
            "cores": os.cpu_count(), "command": "python benchmarks/dynamics_paper_case.py"}
    atomic_write_json(RESULTS / "dynamics_paper_case.json", {"meta": meta, "runs": runs})
    text = report(runs)
    atomic_write_text(RESULTS / "dynamics_paper_case.md", text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())

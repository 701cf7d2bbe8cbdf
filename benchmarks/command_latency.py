"""What the user waits for: each command's whole wall time, and how much of it is the work.

Each case is run as a user runs it, ``optdesign CMD ...`` in a fresh process, ``--rounds``
times; the table gives the median wall time, the start-up (``optdesign --version``: the
interpreter and the command line's imports, the same in every command) and, where the command
reports it, its own work (``solve``'s ``solve_time_s``); the rest is reading the file,
importing what the command needs, evaluating, verifying and writing files and figures.
Writes benchmarks/results/command_latency.md and .json.

    python benchmarks/command_latency.py [--rounds 3]
"""
from __future__ import annotations

import argparse
import json
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
PROGRAM = [sys.executable, "-m", "optdesign"]

#: (label, arguments after ``optdesign``; OUT is replaced by a fresh folder)
CASES = [
    ("start-up (--version)", ["--version"]),
    ("analyze sharkov2022", ["analyze", "problems/sharkov2022.yaml"]),
    ("solve sharkov2022_disc", ["solve", "problems/sharkov2022_disc.yaml", "--out", "OUT",
                                "--json"]),
    ("solve sharkov2022_disc --no-plots", ["solve", "problems/sharkov2022_disc.yaml", "--out",
                                           "OUT", "--json", "--no-plots"]),
    ("export sharkov2022", ["export", "problems/sharkov2022.yaml", "--out", "OUT"]),
    ("animate sharkov2022", ["animate", "problems/sharkov2022.yaml", "--out", "OUT"]),
    ("simulate sharkov2022_dynamics", ["simulate", "problems/sharkov2022_dynamics.yaml",
                                       "--out", "OUT"]),
]


def run_once(args: list[str]) -> tuple[float, float | None]:
    """(wall seconds, the command's own reported work in seconds or None) of one run."""
    with tempfile.TemporaryDirectory() as scratch:
        argv = [scratch if a == "OUT" else a for a in args]
        t0 = time.perf_counter()
        done = subprocess.run(PROGRAM + argv, cwd=ROOT, capture_output=True, text=True)
        wall = time.perf_counter() - t0
    if done.returncode not in (0, 1):
        raise RuntimeError(f"optdesign {' '.join(args)}: exit {done.returncode}\n"
                           f"{done.stderr[-2000:]}")
    work = None
    if "--json" in args and args[0] == "solve":
        work = json.loads(done.stdout)["solve_time_s"]
    return wall, work


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()
    rows = []
    for label, argv in CASES:
        runs = [run_once(argv) for _ in range(args.rounds)]
        walls = [w for w, _ in runs]
        works = [x for _, x in runs if x is not None]
        rows.append({"case": label, "command": "optdesign " + " ".join(
            a if a != "OUT" else "DIR" for a in argv), "wall_s": walls,
            "median_wall_s": statistics.median(walls),
            "median_work_s": statistics.median(works) if works else None})
    start = rows[0]["median_wall_s"]
    lines = [f"Whole wall time of each command [s], a fresh process each, median of "
             f"{args.rounds} runs; start-up is `optdesign --version` (the interpreter and the "
             f"command line); the work is what the command reports of itself (`solve_time_s`).",
             "", "| case | wall (median) | start-up | the command's own work | the rest |",
             "|---|---|---|---|---|"]
    for r in rows[1:]:
        work = r["median_work_s"]
        rest = r["median_wall_s"] - start - (work or 0.0)
        lines.append(f"| `{r['command']}` | {r['median_wall_s']:.2f} | {start:.2f} | "
                     f"{'-' if work is None else f'{work:.2f}'} | {rest:.2f} |")
    RESULTS.mkdir(exist_ok=True)
    meta = {"time": time.strftime("%Y-%m-%d %H:%M:%S"), "python": platform.python_version(),
            "machine": platform.machine() + " " + platform.system(), "rounds": args.rounds}
    (RESULTS / "command_latency.md").write_text("\n".join(lines) + "\n")
    (RESULTS / "command_latency.json").write_text(json.dumps({"meta": meta, "rows": rows},
                                                             indent=2) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())

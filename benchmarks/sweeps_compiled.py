"""A front and an atlas now, on compiled derivatives, against the same before.

The NLP's derivatives compiled to C (:mod:`optdesign.solver.compiled`) make each IPOPT run
two to four times faster with the same iterates; a Pareto sweep and an atlas are hundreds of
IPOPT runs. This measures what that gives a user, whole processes as the user waits for them
(start-up, the sweep, the report and its figures):

* ``optdesign pareto P.yaml --workers 2`` for the four fronts of
  ``benchmarks/pareto_vs_peers.py`` (pareto_fourbar, pareto_disc_three_counts,
  pareto_slotted_forward, pareto_reverse_flat);
* ``optdesign atlas`` of the 16-cell slice of ``benchmarks/atlas_scaling.py`` (n = 5–8 ×
  μ_min = 35–50°, ratio ≥ 0.3) with ``--workers 2``;

each three ways, alternating for ``--pairs`` rounds so that all three meet the same machine
(the ratios taken round by round):

* **before**: the code of ``--before`` (default ``ec4c3c0``, the last commit before the NLP's
  derivatives were compiled, where the work on the solve's floor began), exported from this
  repository's history into a temporary folder and run from there;
* **virtual machine**: this code with ``OPTDESIGN_COMPILE=off`` (the NumPy lanes too);
* **compiled**: this code with ``OPTDESIGN_COMPILE=load`` (the libraries in the user's cache:
  the NLPs' derivatives and the lanes compiled to C).

"The sweep alone": the command's own clock of its sweep (``run.wall_time_s`` in pareto.json
or atlas.json: the points or cells solved, from the pool's start to the last answer), without
the start-up, the report and its figures, which a compiled library does not touch; the whole
process is what the user waits for, the sweep what the compiled derivatives speed up.

"Same answer": the front's points (pareto.csv) and the atlas's cells (atlas.csv) of the first
round equal in every column but the
times and the warm starts' count, and the front's hypervolume (``optdesign.fronts.indicators``)
equal to the bit; "largest δ gap", the most any point's or cell's δ differs between the two
runs (an atlas on two workers warm-starts a cell from the neighbours solved before it, which
the order the workers finish in decides: its δ may move in the last digits between any two
runs, compiled or not). The code of ec4c3c0 moves a few of the slotted lever's points'
iterations and multipliers between runs (its workers kept a solver, and with it NLPs of more
hand-over slots, from task to task): its "same answer" reads no there, the designs, δ and the
hypervolume equal to the bit.

Before measuring, every NLP the runs build is compiled into the user's cache: each command is
run with ``OPTDESIGN_COMPILE=on`` (which starts the build of an NLP it finds no library of,
one at a time) and the builds waited for, until a run loads a library for every NLP it builds.

    python benchmarks/sweeps_compiled.py [--pairs 3] [--before REV]

Writes benchmarks/results/sweeps_compiled.md and its JSON twin.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import re
import statistics
import sys
import tempfile
import time
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from atlas_scaling import slice_file  # noqa: E402
from optdesign.outputs.atomic import atomic_write_text  # noqa: E402
from warm_cache import exported, run, warm_up  # noqa: E402

RESULTS = ROOT / "benchmarks" / "results"
OPTDESIGN = [sys.executable, "-m", "optdesign"]
MODES = {"before": "off", "virtual machine": "off", "compiled": "load"}
#: columns that hold times, or the warm starts a cell had (the workers' order), not answers
NOT_ANSWERS = re.compile(r"(^|_)(time|seconds|finished|started)(_|$)|_s$|^neighbours$")


#: the fronts of ``benchmarks/pareto_vs_peers.py``, pareto_fourbar first
FRONTS = ("pareto_fourbar", "pareto_disc_three_counts", "pareto_slotted_forward",
          "pareto_reverse_flat")


def commands(folder: Path) -> dict[str, tuple[list[str], str]]:
    """name: (the command without its --out, the table it writes)."""
    fronts = {f"{name} front": ([*OPTDESIGN, "pareto", str(ROOT / "problems" / f"{name}.yaml"),
                                 "--workers", "2"], "pareto.csv") for name in FRONTS}
    return fronts | {"atlas slice (16 cells)": ([*OPTDESIGN, "atlas", str(slice_file(folder)),
                                                 "--workers", "2"], "atlas.csv")}


def answers(table: Path) -> pd.DataFrame:
    frame = pd.read_csv(table)
    return frame[[c for c in frame.columns if not NOT_ANSWERS.search(c)]]


def sweep_seconds(folder: Path) -> float | None:
    """The command's own clock of its sweep (``run.wall_time_s`` of pareto.json or
    atlas.json), or None where it wrote none."""
    for name in ("pareto.json", "atlas.json"):
        path = folder / name
        if path.exists():
            return json.loads(path.read_text()).get("run", {}).get("wall_time_s")
    return None


def hypervolume(folder: Path) -> float | None:
    path = folder / "pareto.json"
    if not path.exists():
        return None
    return json.loads(path.read_text())["indicators"].get("hypervolume")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--pairs", type=int, default=3)
    ap.add_argument("--before", default="ec4c3c0")
    args = ap.parse_args()
    log = lambda text: print(text, file=sys.stderr, flush=True)  # noqa: E731
    rows, raw = [], {}
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        code = {"before": exported(args.before, folder)}
        for name, (command, table) in commands(folder).items():
            warm_up(name, command, folder, log)
            walls = {m: [] for m in MODES}
            sweeps = {m: [] for m in MODES}
            tables, volumes = {}, {}
            for k in range(args.pairs):
                for label, mode in MODES.items():
                    out = folder / f"{name.split()[0]}-{mode}-{k}"
                    wall, _ = run(command, out, mode, code=code.get(label))
                    walls[label].append(wall)
                    sweeps[label].append(sweep_seconds(out))
                    tables.setdefault(label, answers(out / table))
                    volumes.setdefault(label, hypervolume(out))
                    log(f"{name}, {label}: {wall:.2f} s")
            after = tables["compiled"]
            row = {"name": name, "rows": len(after), "hypervolume": volumes["compiled"],
                   "walls_s": walls, "sweeps_s": sweeps}
            for label in ("before", "virtual machine"):
                ratios = [a / b for a, b in zip(walls[label], walls["compiled"])]
                other = tables[label]
                row[label] = {
                    "ratios": ratios, "median_ratio": statistics.median(ratios),
                    "same_answer": other.equals(after) and volumes[label] == volumes["compiled"],
                    "largest_delta_gap": float((other["delta"] - after["delta"]).abs().max())
                    if len(other) == len(after) else float("nan"),
                    "hypervolume": volumes[label]}
                if all(sweeps[label]) and all(sweeps["compiled"]):
                    row[label]["sweep_ratios"] = [a / b for a, b in zip(sweeps[label],
                                                                          sweeps["compiled"])]
            raw[name] = row
            rows.append(row)
    stamp = time.strftime("%Y-%m-%d %H:%M:%S")
    machine = f"{platform.machine()} {platform.system()}"
    where = f"{machine}, {os.cpu_count()} cores"
    lines = [f"Whole processes, `--workers 2`, the three runs alternating ({args.pairs} rounds; "
             f"medians; each ratio round by round, its range in brackets). Before: the code "
             f"of `{args.before}`; the virtual machine: this code with `OPTDESIGN_COMPILE=off`; "
             f"compiled: this code, every NLP's library and the lanes' in the user's cache.", "",
             "| run | before [s] | virtual machine [s] | compiled [s] | before / compiled | "
             "virtual machine / compiled | points or cells | hypervolume (before, now) | "
             "largest δ gap, before / virtual machine | same answer, before / virtual machine |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for row in rows:
        med = {k: statistics.median(v) for k, v in row["walls_s"].items()}
        b, v = row["before"], row["virtual machine"]
        ratio = lambda r: (f"{r['median_ratio']:.2f}× ({min(r['ratios']):.2f}–"  # noqa: E731
                           f"{max(r['ratios']):.2f})")
        volume = "–" if row["hypervolume"] is None else \
            f"{b['hypervolume']:.10f}, {row['hypervolume']:.10f}"
        lines.append(f"| {row['name']} | {med['before']:.2f} | {med['virtual machine']:.2f} | "
                     f"{med['compiled']:.2f} | {ratio(b)} | {ratio(v)} | {row['rows']} | "
                     f"{volume} | {b['largest_delta_gap']:.1e} / {v['largest_delta_gap']:.1e} | "
                     f"{'yes' if b['same_answer'] else 'no'} / "
                     f"{'yes' if v['same_answer'] else 'no'} |")
    lines += ["", "The sweep alone (the command's own clock of it: start-up, report and "
              "figures left out):", "",
              "| run | before [s] | virtual machine [s] | compiled [s] | before / compiled | "
              "virtual machine / compiled |", "|---|---|---|---|---|---|"]
    for row in rows:
        if "sweep_ratios" not in row["before"]:
            continue
        med = {k: statistics.median(v) for k, v in row["sweeps_s"].items()}
        spread = lambda r: (f"{statistics.median(r):.2f}× ({min(r):.2f}–"  # noqa: E731
                            f"{max(r):.2f})")
        lines.append(f"| {row['name']} | {med['before']:.2f} | {med['virtual machine']:.2f} | "
                     f"{med['compiled']:.2f} | {spread(row['before']['sweep_ratios'])} | "
                     f"{spread(row['virtual machine']['sweep_ratios'])} |")
    lines += ["", f"measured on {where}, {stamp} (Python {platform.python_version()})"]
    RESULTS.mkdir(parents=True, exist_ok=True)
    atomic_write_text(RESULTS / "sweeps_compiled.md", "\n".join(lines) + "\n")
    atomic_write_text(RESULTS / "sweeps_compiled.json",
                      json.dumps({"meta": {"time": stamp, "machine": machine,
                                           "cores": os.cpu_count(),
                                           "python": platform.python_version(),
                                           "pairs": args.pairs, "before": args.before},
                                  "runs": raw}, indent=1))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())

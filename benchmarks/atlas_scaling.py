"""How fast an atlas is computed, and what a large one would take.

On a 16-cell slice of ``problems/atlas_fourbar.yaml`` (n = 5–8 × μ_min = 35–50°, ratio floor
0.3): cells per second on 1 and 2 local workers and on a local Dask cluster of 2 worker
processes (one thread each); the cost of warm starts (each warm-started cell of the 1-worker
run solved again cold, in this process, without its neighbours' optima); the Dask
scheduler's overhead per task (200 empty tasks); and from the shipped atlas's per-cell cost
(``benchmarks/results/atlas_fourbar/atlas.csv``, n = 3–12) a projection of a 10⁴-cell atlas
on N machines: cells × CPU per cell / (N × cores) + cells × the scheduler's overhead per task
(the scheduler hands tasks out one at a time, so that part does not shrink with N).

Every cell's NLP is compiled into the user's cache first (``optdesign atlas`` run until it
loads a library for each, :mod:`warm_cache`), and the local runs are timed on the compiled
derivatives and on CasADi's virtual machine (``OPTDESIGN_COMPILE=off``), alternating.

    python benchmarks/atlas_scaling.py      # about two minutes on 2 cores (compiles first)

Writes benchmarks/results/atlas_scaling.md and its JSON twin.
"""
from __future__ import annotations

import copy
import json
import os
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from optdesign.numerics import user_cache  # noqa: E402
from warm_cache import warm_up  # noqa: E402

RESULTS = ROOT / "benchmarks" / "results"
SHIPPED = RESULTS / "atlas_fourbar" / "atlas.csv"
CELLS_PROJECTED = 10_000
#: rounds of the local runs, the virtual machine's and the compiled one alternating
ROUNDS = 2
#: OPTDESIGN_COMPILE of the two modes
MODES = ("off", "load")
MACHINES = (1, 10, 100, 1000)
CORES_PER_MACHINE = 2          # as the machine measured here
EMPTY_TASKS = 200


def slice_data() -> dict:
    """The slice as an atlas file's mapping."""
    data = yaml.safe_load((ROOT / "problems" / "atlas_fourbar.yaml").read_text())
    data = copy.deepcopy(data)
    data["name"] = "atlas_slice"
    data["axes"] = {"phases": {"lower": 5, "upper": 8, "step": 1},
                    "min_transmission_angle_deg": {"lower": 35, "upper": 50, "step": 5}}
    data["fixed"] = dict(data["fixed"]) | {"min_ratio": 0.3}
    return data


def slice_file(folder: Path) -> Path:
    """The slice written as an atlas file into ``folder``, for the command to read."""
    path = folder / "atlas_slice.yaml"
    path.write_text(yaml.safe_dump(slice_data(), sort_keys=False))
    return path


def slice_spec():
    from optdesign.atlas.spec import atlas_from_dict

    return atlas_from_dict(slice_data(), "atlas_fourbar.yaml (slice)")


def timed_run(spec, **kwargs):
    from optdesign.atlas.run import run_atlas

    with tempfile.TemporaryDirectory() as out:
        t0 = time.perf_counter()
        result = run_atlas(spec, out, progress=False, **kwargs)
        wall = time.perf_counter() - t0
    return result, wall


def scheduler_overhead(client) -> float:
    """Seconds per task of the scheduler's round trip: empty tasks, submitted and gathered."""
    client.gather(client.map(abs, range(10), pure=False))          # warm the workers
    t0 = time.perf_counter()
    client.gather(client.map(abs, range(EMPTY_TASKS), pure=False))
    return (time.perf_counter() - t0) / EMPTY_TASKS


def warm_against_cold(spec, result) -> dict:
    """Every warm-started cell of ``result`` solved again without its neighbours."""
    from optdesign.atlas.worker import solve_cell

    cells = spec.cells()
    warm_s, cold_s, gaps = [], [], []
    for rec in result.records:
        if rec["neighbours"] == 0 or rec.get("repair"):
            continue
        cell = cells[rec["cell"]]
        cold = solve_cell(spec.problem(cell), cell.index, spec.values_of(cell), [])
        warm_s.append(rec["time_s"])
        cold_s.append(cold["time_s"])
        if rec["feasible"] and cold["feasible"]:
            gaps.append(abs(rec["delta"] - cold["delta"]))
    return {"cells": len(warm_s), "warm_s": sum(warm_s), "cold_s": sum(cold_s),
            "max_delta_gap": max(gaps) if gaps else None}


def main() -> int:
    import pandas as pd
    from distributed import Client, LocalCluster

    spec = slice_spec()
    n = len(spec.cells())
    with tempfile.TemporaryDirectory() as tmp:      # every cell's NLP compiled beforehand
        warm_up("the atlas slice", [sys.executable, "-m", "optdesign", "atlas",
                                    str(slice_file(Path(tmp))), "--workers", "2"], Path(tmp),
                print)
    rows, machine = [], {}
    for label, workers in (("1 local worker (in process)", 1), ("2 local workers (forked)", 2)):
        walls, last = {mode: [] for mode in MODES}, {}
        for _ in range(ROUNDS):             # the two modes alternating, on the same load
            for mode in MODES:
                os.environ[user_cache.VARIABLE] = mode
                last[mode], wall = timed_run(spec, workers=workers)
                walls[mode].append(wall)
        machine[label] = statistics.median(walls["off"])
        rows.append((label, statistics.median(walls["load"]), last["load"]))
    os.environ[user_cache.VARIABLE] = "load"
    one = rows[0][2]
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        overhead = scheduler_overhead(client)
        dask_result, wall = timed_run(spec, scheduler=client)
        rows.append(("local Dask cluster, 2 workers", wall, dask_result))
    warm = warm_against_cold(spec, one)
    shipped = pd.read_csv(SHIPPED)
    per_cell = float(shipped["time_s"].mean())

    lines = [f"Cells per second on a {n}-cell slice of `problems/atlas_fourbar.yaml` (n = 5–8 × "
             f"μ_min = 35–50°, ratio ≥ 0.3), each run from its first cell to its last "
             f"(repairs included), in this process, every cell's NLP compiled into the user's "
             f"cache beforehand; the local runs also on CasADi's virtual machine "
             f"(`OPTDESIGN_COMPILE=off`, the runs before the derivatives were compiled), the "
             f"two alternating ({ROUNDS} rounds, medians).", "",
             "| run | cells | wall [s] | cells/s | a cell's solve, mean [s] | repairs | "
             "wall on the virtual machine [s] | cells/s, compiled / virtual machine |",
             "|---|---|---|---|---|---|---|---|"]
    for label, wall, res in rows:
        cpu = statistics.mean(r["time_s"] for r in res.records)
        vm = machine.get(label)
        lines.append(f"| {label} | {n} | {wall:.1f} | {n / wall:.2f} | {cpu:.2f} | "
                     f"{res.run['repairs']} | " + ("- | - |" if vm is None else
                                                  f"{vm:.1f} | {vm / wall:.2f}× |"))
    lines += ["", "| warm-started cells solved again cold | warm: their solves [s] | cold: "
              "their solves [s] | cold / warm | largest δ gap |", "|---|---|---|---|---|",
              f"| {warm['cells']} | {warm['warm_s']:.1f} | {warm['cold_s']:.1f} | "
              f"{warm['cold_s'] / warm['warm_s']:.2f} | "
              f"{warm['max_delta_gap']:.1e} |" if warm["cells"] else "| 0 | - | - | - | - |"]
    lines += ["", f"Projection of a {CELLS_PROJECTED}-cell atlas: {per_cell:.2f} s per "
              f"cell (the mean over the shipped atlas, n = 3–12), {CORES_PER_MACHINE} cores a "
              f"machine, and the Dask scheduler's {overhead * 1e3:.2f} ms per task measured "
              f"here (serial: it does not shrink with N); the projected wall time is the "
              f"larger of the two, which overlap.", "",
              "| machines N | cores | compute [s] | scheduler [s] | projected wall |",
              "|---|---|---|---|---|"]
    projection = []
    for machines in MACHINES:
        cores = machines * CORES_PER_MACHINE
        compute = CELLS_PROJECTED * per_cell / cores
        sched = CELLS_PROJECTED * overhead
        total = max(compute, sched) if cores > 1 else compute + sched
        projection.append({"machines": machines, "cores": cores, "compute_s": compute,
                           "scheduler_s": sched, "wall_s": total})
        lines.append(f"| {machines} | {cores} | {compute:.0f} | {sched:.1f} | "
                     f"{_duration(total)} |")
    RESULTS.mkdir(exist_ok=True)
    meta = {"time": time.strftime("%Y-%m-%d %H:%M:%S"), "python": platform.python_version(),
            "machine": platform.machine() + " " + platform.system(),
            "cores": os.cpu_count()}
    (RESULTS / "atlas_scaling.md").write_text("\n".join(lines) + "\n")
    (RESULTS / "atlas_scaling.json").write_text(json.dumps({
        "meta": meta, "cells": n,
        "runs": [{"run": label, "wall_s": wall, "cells_per_s": n / wall,
                  "repairs": res.run["repairs"],
                  "wall_virtual_machine_s": machine.get(label)} for label, wall, res in rows],
        "warm_against_cold": warm, "scheduler_overhead_s": overhead,
        "per_cell_s": per_cell, "projection": projection}, indent=2) + "\n")
    print("\n".join(lines))
    return 0


def _duration(seconds: float) -> str:
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"


if __name__ == "__main__":
    sys.exit(main())

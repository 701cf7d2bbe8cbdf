"""What the user waits for: each command's whole wall time, split into its phases.

Each case is run as a user runs it, ``optdesign CMD ...`` in a fresh process, ``--rounds``
times, round after round (the cases alternate, so a busy moment of a shared machine spreads
over all of them). Every run is timed from outside (the wall, and the first byte on stdout:
the printed answer) and, with ``OPTDESIGN_PHASES`` set, from inside
(:mod:`optdesign.outputs.phases`): the command's phases and the wall clock at its first line.
A run's wall time is split into

* start-up and imports: the interpreter, the command line and every ``imports`` phase (a
  library imported inside another phase, e.g. matplotlib by the first figure, counts there);
* reading: the problem file (and a ``--design`` file) read and checked;
* solving or evaluating: the solve, the simulation, the exact evaluation;
* verification: for ``solve``, the exact re-verification of its optima, as the solver
  reports it (``timings_s``; taken out of the solving);
* files and figures: the files without a figure, then the figures (drawn beside by the
  figures' process, waited for);
* other: the rest (between phases, and the interpreter's exit);

and the answer is when it came: the first byte on stdout. Each column is the median of its
runs (so the columns need not add up to the median wall).

Each case runs twice in each round, back to back: in a process of its own
(``OPTDESIGN_SERVER=off``, the first command of a session), and handed to a warm server
(:mod:`optdesign.warm`, started once before the first round in a folder of the benchmark's,
stopped after the last). A third table sets the targets against both: ``analyze``'s wall, and
``solve``'s wall beyond the ``solve_time_s`` it reports itself (the median of each run's own
difference). Writes
benchmarks/results/command_latency.md and .json. With ``--compare TREE`` every case is run
on the code of TREE too, right after its run here (a worktree of another commit), and that is
written as benchmarks/results/command_latency_before.md and .json; a second table sets the
wall and the answer of both side by side (read from that file when it is there, so a run
without ``--compare`` keeps the comparison of the last run that made one).

    python benchmarks/command_latency.py [--rounds 3] [--compare TREE --compare-name NAME]

The "before" file is the commit before the latency work, 7b38b25, in a worktree:

    git worktree add /tmp/base 7b38b25
    python benchmarks/command_latency.py --compare /tmp/base --compare-name "commit 7b38b25"

``pareto`` is left out: even ``--points 2 --no-report`` on the shipped fronts takes 20-45 s (its
refinement rounds), more than the whole benchmark.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
PROGRAM = [sys.executable, "-m", "optdesign"]
#: the tree compared (``--compare``): the commit before the latency work, 7b38b25
BEFORE = RESULTS / "command_latency_before.json"

#: (label, arguments after ``optdesign``; OUT is replaced by a fresh folder)
CASES = [
    ("start-up (--version)", ["--version"]),
    ("analyze sharkov2022", ["analyze", "problems/sharkov2022.yaml"]),
    ("solve sharkov2022_disc", ["solve", "problems/sharkov2022_disc.yaml", "--out", "OUT",
                                "--json"]),
    ("solve sharkov2022_disc --no-plots", ["solve", "problems/sharkov2022_disc.yaml", "--out",
                                           "OUT", "--json", "--no-plots"]),
    ("curves sharkov2022", ["curves", "problems/sharkov2022.yaml", "--out", "OUT"]),
    ("simulate sharkov2022_dynamics", ["simulate", "problems/sharkov2022_dynamics.yaml",
                                       "--out", "OUT"]),
    ("tolerance sharkov2022_disc_tolerance", ["tolerance",
                                              "problems/sharkov2022_disc_tolerance.yaml",
                                              "--out", "OUT"]),
    ("driveline driveline", ["driveline", "problems/driveline.yaml", "--out", "OUT"]),
    ("export sharkov2022", ["export", "problems/sharkov2022.yaml", "--out", "OUT"]),
    ("animate sharkov2022", ["animate", "problems/sharkov2022.yaml", "--out", "OUT"]),
]

#: the columns of the split, and the phases each sums
COLUMNS = {"start-up and imports": ("imports",), "reading": ("reading",),
           "solving or evaluating": ("solving", "evaluating"), "verification": (),
           "files": ("files",), "figures": ("figures",)}
PHASE_VARIABLE = "OPTDESIGN_PHASES"
#: the warm server's folder during the benchmark (a private one of its own)
WARM_FOLDER = Path(tempfile.gettempdir()) / f"optdesign-bench-{os.getuid()}"
#: the targets: ``analyze`` of the paper's design, and ``solve`` on the disc problem with its
#: figures beyond the solve time it reports [s]
TARGETS = {"analyze sharkov2022": 0.5, "solve sharkov2022_disc": 0.5}


def setup_env(tree: Path, warm: bool) -> dict:
    """The environment of a run of ``tree``'s code: with its own warm server (in a folder of
    the benchmark's), or with none."""
    # `python -m` puts the working folder first on sys.path: the tree's own package runs
    env = os.environ | {"PYTHONPATH": str(tree), "OPTDESIGN_SERVER": "on" if warm else "off"}
    return env | ({"OPTDESIGN_SERVER_DIR": str(WARM_FOLDER)} if warm else {})


def run_once(args: list[str], tree: Path = ROOT, warm: bool = False) -> dict:
    """One run of the code in ``tree``: its wall, the first byte on stdout, its phase record
    (None from a tree without the phase clock) and what ``solve --json`` reports of itself."""
    with tempfile.TemporaryDirectory() as scratch:
        argv = [scratch + "/out" if a == "OUT" else a for a in args]
        log = Path(scratch) / "phases.jsonl"
        env = setup_env(tree, warm) | {PHASE_VARIABLE: str(log)}
        spawned = time.time()
        t0 = time.perf_counter()
        proc = subprocess.Popen(PROGRAM + argv, cwd=tree, env=env, stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE)
        err: list[bytes] = []
        drain = threading.Thread(target=lambda: err.append(proc.stderr.read()), daemon=True)
        drain.start()
        first, chunks = None, []
        while chunk := proc.stdout.read1(1 << 16):
            if first is None:
                first = time.perf_counter() - t0
            chunks.append(chunk)
        code = proc.wait()
        wall = time.perf_counter() - t0
        drain.join()
        record = json.loads(log.read_text().splitlines()[-1]) if log.exists() else None
    out = b"".join(chunks).decode("utf-8", "replace")
    if code not in (0, 1):
        raise RuntimeError(f"optdesign {' '.join(args)}: exit {code}\n"
                           f"{b''.join(err).decode('utf-8', 'replace')[-2000:]}")
    reported = json.loads(out) if "--json" in args and args[0] == "solve" else {}
    return {"wall_s": wall, "answer_s": first if first is not None else wall,
            "spawn_to_start_s": record["started"] - spawned if record else None,
            "phases": record["phases"] if record else None,
            "exit_s": record["exit_s"] if record else None,
            "solve_time_s": reported.get("solve_time_s"),
            "verification_s": (reported.get("timings_s") or {}).get("verification")}


def split(run: dict) -> dict[str, float] | None:
    """The run's wall time by column (None without a phase record)."""
    if run["phases"] is None:
        return None
    phases = run["phases"]
    spent = {name: sum(end - start for n, start, end in phases if n == name)
             for name in {p[0] for p in phases}}
    first = min((start for _, start, _ in phases), default=0.0)
    out = {column: sum(spent.get(n, 0.0) for n in names) for column, names in COLUMNS.items()}
    out["start-up and imports"] += run["spawn_to_start_s"] + first
    verification = min(run["verification_s"] or 0.0, out["solving or evaluating"])
    out["verification"] = verification if run["verification_s"] is not None else None
    out["solving or evaluating"] -= verification
    out["other"] = run["wall_s"] - sum(v or 0.0 for v in out.values())
    return out


def median_row(label: str, argv: list[str], runs: list[dict]) -> dict:
    splits = [s for s in map(split, runs) if s is not None]
    row = {"case": label, "command": "optdesign " + " ".join(
        a if a != "OUT" else "DIR" for a in argv),
        "wall_s": [r["wall_s"] for r in runs], "answer_s": [r["answer_s"] for r in runs],
        "median_wall_s": statistics.median(r["wall_s"] for r in runs),
        "median_answer_s": statistics.median(r["answer_s"] for r in runs),
        "median_solve_time_s": _median([r["solve_time_s"] for r in runs]),
        "runs": runs, "median_split_s": None}
    if splits:
        row["median_split_s"] = {k: _median([s[k] for s in splits]) for k in splits[0]}
    return row


def _median(values):
    values = [v for v in values if v is not None]
    return statistics.median(values) if values else None


def _cell(value) -> str:
    return "-" if value is None else f"{value:.2f}"


def split_table(rows: list[dict], heading: str) -> list[str]:
    """The medians of each command's wall, answer and phases, under ``heading``."""
    columns = list(COLUMNS) + ["other"]
    lines = [heading, "", "| command | wall | answer at | " + " | ".join(columns) + " |",
             "|---|---|---|" + "---|" * len(columns)]
    for r in rows:
        split_ = r["median_split_s"] or {}
        lines.append(f"| `{r['command']}` | {r['median_wall_s']:.2f} | "
                     f"{r['median_answer_s']:.2f} | "
                     + " | ".join(_cell(split_.get(c)) for c in columns) + " |")
    return lines


def tables(rows: list[dict], rounds: int, before: dict | None,
           warm: list[dict] | None = None) -> list[str]:
    lines = split_table(rows, f"Wall time of each command [s], a fresh process each (no warm "
                              f"server), median of {rounds} runs, split into its phases "
                              f"(`OPTDESIGN_PHASES`); the answer is the first byte on stdout, "
                              f"the printed result.")
    if warm:
        lines += [""] + split_table(warm, f"The same commands handed to a warm server "
                                          f"(`optdesign server start` before the first "
                                          f"round), median of {rounds} runs:")
        lines += [""] + target_lines(rows, warm)
    if before:
        old = {r["command"]: r for r in before["rows"]}
        now = {r["command"]: r for r in warm or []}
        lines += ["", f"Before and now [s] (medians; before: {before['meta'].get('tree', '?')}"
                      f", {before['meta']['time']}):", "",
                  "| command | wall before | wall now | wall now, warm | answer before | "
                  "answer now | answer now, warm |", "|---|---|---|---|---|---|---|"]
        for r in rows:
            b, w = old.get(r["command"]), now.get(r["command"])
            lines.append(f"| `{r['command']}` | "
                         f"{_cell(b and b['median_wall_s'])} | {r['median_wall_s']:.2f} | "
                         f"{_cell(w and w['median_wall_s'])} | "
                         f"{_cell(b and b['median_answer_s'])} | "
                         f"{r['median_answer_s']:.2f} | {_cell(w and w['median_answer_s'])} |")
    return lines


def target_lines(cold: list[dict], warm: list[dict]) -> list[str]:
    """The targets, as measured: ``analyze``'s wall; ``solve``'s wall beyond its solve
    time (both medians of the runs' own differences)."""
    lines = ["| target | cold | warm | target |", "|---|---|---|---|"]
    for case, limit in TARGETS.items():
        got = []
        for rows in (cold, warm):
            row = next(r for r in rows if r["case"] == case)
            if row["median_solve_time_s"] is None:
                got.append(row["median_wall_s"])
            else:
                got.append(statistics.median(r["wall_s"] - r["solve_time_s"]
                                             for r in row["runs"]))
        what = ("wall beyond `solve_time_s`" if case.startswith("solve") else "wall")
        lines.append(f"| `{case}`: {what} | {got[0]:.2f} | {got[1]:.2f} | "
                     f"<= {limit:g} ({'met' if got[1] <= limit else 'not met'} warm) |")
    return lines


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--compare", type=Path, metavar="TREE",
                    help="also run every case on the code of TREE, alternating with this "
                         "tree's run of it, and write that as the --before file")
    ap.add_argument("--compare-name", default="the tree compared",
                    help="what TREE is, for the tables (e.g. 'commit 7b38b25')")
    ap.add_argument("--before", type=Path, default=BEFORE,
                    help="the JSON of the tree compared (default: "
                         "benchmarks/results/command_latency_before.json): written with "
                         "--compare, read otherwise, if there")
    ap.add_argument("--out", type=Path, default=RESULTS / "command_latency.md",
                    help="the results file (its JSON twin beside it)")
    args = ap.parse_args()
    trees = {"now": (ROOT, False), "warm": (ROOT, True)} | (
        {"before": (args.compare, False)} if args.compare else {})
    runs = {(tree, label): [] for tree in trees for label, _ in CASES}
    _server("start")
    try:
        for _ in range(args.rounds):
            for label, argv in CASES:
                for tree, (root, warm) in trees.items():    # back to back: the same load
                    runs[(tree, label)].append(run_once(argv, root, warm))
    finally:
        _server("stop")
    rows = {tree: [median_row(label, argv, runs[(tree, label)]) for label, argv in CASES]
            for tree in trees}
    meta = {"time": time.strftime("%Y-%m-%d %H:%M:%S"), "python": platform.python_version(),
            "machine": platform.machine() + " " + platform.system(),
            "cores": os.cpu_count(), "rounds": args.rounds}
    before_json = args.before.with_suffix(".json")
    if args.compare:
        _write(before_json.with_suffix(".md"), tables(rows["before"], args.rounds, None),
               {"meta": meta | {"tree": args.compare_name}, "rows": rows["before"]})
    before = json.loads(before_json.read_text()) if before_json.is_file() else None
    lines = tables(rows["now"], args.rounds, before, rows["warm"])
    _write(args.out, lines, {"meta": meta | {"tree": "this tree"}, "rows": rows["now"],
                             "warm_rows": rows["warm"]})
    print("\n".join(lines))
    return 0


def _server(action: str) -> None:
    """Start (and wait for) or stop this tree's warm server in the benchmark's folder."""
    subprocess.run(PROGRAM + ["server", action], cwd=ROOT, env=setup_env(ROOT, True),
                   check=True, stdout=subprocess.DEVNULL)


def _write(path: Path, lines: list[str], doc: dict) -> None:
    """A results file (its tables; ``path`` ends .md) and its JSON twin."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n")
    path.with_suffix(".json").write_text(json.dumps(doc, indent=2) + "\n")


if __name__ == "__main__":
    sys.exit(main())

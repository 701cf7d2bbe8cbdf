"""Our solve time at two commits, side by side on one machine: is a change slower, or the
machine?

Times taken on different days compare machines as much as code (the shared machines drift by
tens of per cent). This puts the code of ``--base`` (a git worktree in a temporary folder) and
the working tree under the same conditions: each case solved in a fresh process by
``benchmarks/solve_vs_peers.py --_ours CASE`` (the solve race's own timing, around the call
alone), the two trees alternating, ``--rounds`` times, with this interpreter (one venv: the
tree is chosen by PYTHONPATH). Writes benchmarks/results/solve_time_ab.md and .json.

With ``--warm K`` each fresh process solves the case once, then ``K`` times more, each after
the evaluator's memory of checked designs is emptied (as ``benchmarks/solve_floor.py`` times
the warm solve), and gives the median of those: the warm solve side by side, written to
benchmarks/results/solve_time_ab_warm.md and .json.

    python benchmarks/solve_time_ab.py --base ee93e2a --cases disc_n6 disc_n12 free_design
        [--rounds 3] [--warm 5]
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
sys.path.insert(0, str(ROOT))

from optdesign.outputs.atomic import atomic_write_text  # noqa: E402


#: a warm process's solves (run with the tree's code): the first, then ``K`` more, each after
#: the evaluator's memory is emptied; the median of those and the last one's figures
WARM_CHILD = """
import json, statistics, sys, time
sys.path.insert(0, "benchmarks")
from solve_vs_peers import load_case, timed_solve
from optdesign.evaluation.figures import forget
problem = load_case(sys.argv[1])
timed_solve(problem)
times = []
for _ in range(int(sys.argv[2])):
    forget()
    result, summary = timed_solve(problem)
    times.append(summary["time_s"])
print("@@OURS@@" + json.dumps({"time_s": statistics.median(times),
                               "iterations": summary["iterations"], "delta": summary["delta"]}))
"""


def solve_time(tree: Path, case: str, warm: int = 0) -> dict:
    """One timed solve of ``case`` with the code of ``tree`` (``warm``: the median of that
    many warm solves of one process): wall seconds and iterations."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    command = [sys.executable, "-c", WARM_CHILD, case, str(warm)] if warm else \
        [sys.executable, "benchmarks/solve_vs_peers.py", "--_ours", case]
    out = subprocess.run(command, cwd=tree, env=env, capture_output=True, text=True)
    line = next((x for x in out.stdout.splitlines() if x.startswith("@@OURS@@")), None)
    if line is None:
        raise RuntimeError(f"{tree}: the solve of {case} failed:\n{out.stderr[-2000:]}")
    data = json.loads(line[len("@@OURS@@"):])
    return {"time_s": data["time_s"], "iterations": data["iterations"], "delta": data["delta"]}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", required=True, help="the commit to compare the working tree with")
    ap.add_argument("--cases", nargs="+", default=["disc_n6", "disc_n12", "free_design"])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--warm", type=int, default=0,
                    help="time the warm solve: the median of this many in each process")
    args = ap.parse_args()
    if not 1 <= args.rounds <= 50 or not 0 <= args.warm <= 50:
        ap.error("--rounds must be 1 to 50 and --warm 0 to 50")
    with tempfile.TemporaryDirectory(prefix="optdesign-ab-") as tmp:
        base = Path(tmp) / "base"
        subprocess.run(["git", "worktree", "add", "--detach", "-q", str(base), args.base],
                       cwd=ROOT, check=True)
        try:
            runs = {(tree, case): [] for tree in ("base", "head") for case in args.cases}
            for _ in range(args.rounds):
                for name, tree in (("base", base), ("head", ROOT)):
                    for case in args.cases:
                        runs[(name, case)].append(solve_time(tree, case, args.warm))
        finally:
            subprocess.run(["git", "worktree", "remove", "--force", str(base)], cwd=ROOT)
    rows = []
    for case in args.cases:
        b, h = runs[("base", case)], runs[("head", case)]
        rows.append({"case": case,
                     "base_s": [r["time_s"] for r in b], "head_s": [r["time_s"] for r in h],
                     "iterations": [b[0]["iterations"], h[0]["iterations"]],
                     "same_delta": all(abs(x["delta"] - b[0]["delta"]) <= 1e-9 * b[0]["delta"]
                                       for x in b + h)})
    how = (f"each a fresh process's median of {args.warm} warm solves, the evaluator's memory "
           f"emptied before each" if args.warm else
           "each a fresh process (`benchmarks/solve_vs_peers.py --_ours`)")
    lines = [f"Our {'warm ' if args.warm else ''}solve time [s] at {args.base} (base) and at "
             f"the working tree (head), side by side: {args.rounds} rounds alternating, "
             f"{how}.", "",
             "| problem | base [s] | head [s] | head / base (medians) | IPOPT iterations "
             "base / head | same δ |", "|---|---|---|---|---|---|"]
    for r in rows:
        mb, mh = (sorted(r[k])[len(r[k]) // 2] for k in ("base_s", "head_s"))
        lines.append(f"| {r['case']} | {', '.join(f'{t:.2f}' for t in r['base_s'])} | "
                     f"{', '.join(f'{t:.2f}' for t in r['head_s'])} | {mh / mb:.2f} | "
                     f"{r['iterations'][0]} / {r['iterations'][1]} | "
                     f"{'yes' if r['same_delta'] else 'no'} |")
    text = "\n".join(lines) + "\n"
    meta = {"base": args.base, "rounds": args.rounds, "warm": args.warm,
            "python": platform.python_version(), "time": time.strftime("%Y-%m-%d %H:%M:%S")}
    name = "solve_time_ab_warm" if args.warm else "solve_time_ab"
    atomic_write_text(RESULTS / f"{name}.md", text)
    atomic_write_text(RESULTS / f"{name}.json",
                      json.dumps({"meta": meta, "results": rows}, indent=1) + "\n")
    print(text, end="")
    return 0


if __name__ == "__main__":
    sys.exit(main())

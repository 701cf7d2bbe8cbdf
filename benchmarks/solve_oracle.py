"""The solver's verdicts against a brute-force oracle, on several hundred random problems.

    python benchmarks/solve_oracle.py [--problems 300] [--seed 0] [--resume] [--table-only]
    python benchmarks/solve_oracle.py --counts 8 12 16 24 --problems 40

Each problem is drawn by ``benchmarks/oracle.py`` (a mechanism, a box spanning one to six
decades with or without initial values, a count, a stroke, random bounds on random quantities
on either side or both, an objective minimised or maximised), solved by ``optdesign.solve``
in-process, and judged against 4096 designs of its box per count, the most promising 48 and the
file's own design checked by the exact evaluator: a false verdict is an ``optimal`` that a
checked design beats (or whose design the exact check rejects), or an ``infeasible`` or
``failed`` where a checked design meets every constraint. Writes
``benchmarks/results/solve_oracle.{json,md}`` (rows kept as they come: ``--resume`` goes on
from the rows written). Also measures the cost of a verdict: the disc problem's feasible solve
against the same file at ``min_ratio: 34.4`` (a per-cent value, out of reach), seven
in-process solves of each in turn: the medians, and the median of the pairs' ratios.

``--counts``: four-bar problems only, each at one of those phase counts (the shipped bases
admit 6 phases alone, so the large draw never meets the windows and slots of 12 or 24):
``benchmarks/results/solve_oracle_counts.{json,md}``, without the verdict's cost.
"""
from __future__ import annotations

import argparse
import copy
import json
import platform
import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import yaml

sys.path.insert(0, str(Path(__file__).resolve().parent))
import oracle  # noqa: E402

from optdesign.outputs.atomic import atomic_write_text  # noqa: E402
from optdesign.problem.loader import problem_from_dict  # noqa: E402
from optdesign.solver import solve  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"


def verdict_cost(rounds: int = 7) -> dict:
    """The disc problem's in-process solve, feasible and at min_ratio 34.4, in turn (a warm-up
    of each first): each one's median time, and the median of the pairs' ratios (pairing keeps
    the ratio meaningful on a machine whose speed drifts)."""
    base = yaml.safe_load((oracle.ROOT / "problems" / "sharkov2022_disc.yaml").read_text())
    far = copy.deepcopy(base)
    far["objective"]["min_ratio"] = 34.4
    cases = (("feasible", base), ("min_ratio 34.4", far))

    def timed(data):
        problem = problem_from_dict(copy.deepcopy(data), where="sharkov2022_disc.yaml")
        t0 = time.perf_counter()
        result = solve(problem)
        return time.perf_counter() - t0, result

    out = {label: {"times": []} for label, _ in cases}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")         # 34.4 is warned as a per-cent ratio: meant so
        for label, data in cases:
            timed(data)
        for _ in range(rounds):
            for label, data in cases:
                seconds, result = timed(data)
                out[label]["times"].append(seconds)
                out[label] |= {"status": result.status, "message": result.message}
    for label, _ in cases:
        out[label]["seconds"] = statistics.median(out[label]["times"])
    out["ratio"] = statistics.median(a / b for a, b in zip(out["min_ratio 34.4"]["times"],
                                                          out["feasible"]["times"]))
    return out


def table(rows: list[dict], cost: dict | None, by_count: bool = False) -> str:
    """The verdicts by mechanism (``by_count``: by phase count), the false ones, and the
    verdict's cost (where measured)."""
    by = {}
    for r in rows:
        key = f"{r['mechanism']}, {r['counts'][0]} phases" if by_count else r["mechanism"]
        by.setdefault(key, []).append(r)
    lines = ["Verdicts of `optdesign.solve` on random problems, each judged against a checked "
             "sample of its box (`benchmarks/oracle.py`).", "",
             "| mechanism | problems | optimal | infeasible | failed | false verdicts | "
             "median solve [s] | boxes [decades] |", "|---|---|---|---|---|---|---|---|"]
    groups = sorted(by.items(), key=lambda item: (item[1][0]["mechanism"],
                                                  item[1][0]["counts"][0] if by_count else 0))
    for mech, rs in groups + [("all", rows)]:
        count = lambda s: sum(r["status"] == s for r in rs)  # noqa: E731
        decades = [r["decades"] for r in rs]
        lines.append(f"| {mech} | {len(rs)} | {count('optimal')} | {count('infeasible')} | "
                     f"{count('failed')} | {sum(r['false'] for r in rs)} | "
                     f"{statistics.median(r['solve_s'] for r in rs):.2f} | "
                     f"{min(decades):.1f}–{max(decades):.1f} |")
    false = [r for r in rows if r["false"]]
    lines += ["", "| false verdict | problem | claim |", "|---|---|---|"]
    lines += [f"| {r['status']} | {r['mechanism']} #{r['seed']} ({r['objective']}; "
              f"{r['bounds'] or 'no bound'}) | {r['claims']} |" for r in false] or \
        ["| none | | |"]
    if cost is None:
        return "\n".join(lines) + "\n"
    f, far = cost["feasible"], cost["min_ratio 34.4"]
    lines += ["", "| the disc problem | status | median solve [s] | / feasible (median of pairs) |", "|---|---|---|---|",
              f"| as shipped | {f['status']} | {f['seconds']:.2f} | 1.0× |",
              f"| min_ratio: 34.4 | {far['status']} | {far['seconds']:.2f} | "
              f"{cost.get('ratio', far['seconds'] / f['seconds']):.1f}× |"]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--problems", type=int, default=300)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--resume", action="store_true")
    ap.add_argument("--table-only", action="store_true",
                    help="the table of the rows written so far (and the verdict cost)")
    ap.add_argument("--counts", type=int, nargs="+", default=(),
                    help="four-bar problems at these phase counts (their own results files)")
    args = ap.parse_args(argv)
    name = "solve_oracle_counts" if args.counts else "solve_oracle"
    path = RESULTS / f"{name}.json"
    rows = json.loads(path.read_text())["rows"] \
        if (args.resume or args.table_only) and path.exists() else []
    rng = np.random.default_rng(args.seed)
    draws = [oracle.random_draw(rng, i, tuple(args.counts)) for i in range(args.problems)]
    meta = {"time": time.strftime("%Y-%m-%d %H:%M:%S"), "python": platform.python_version(),
            "machine": f"{platform.machine()} {platform.system()}", "seed": args.seed,
            **({"counts": list(args.counts)} if args.counts else {})}
    for draw in [] if args.table_only else draws[len(rows):]:
        rows.append(oracle.run(draw))
        atomic_write_text(path, json.dumps({"meta": meta, "rows": rows}, indent=1))
        r = rows[-1]
        print(f"{len(rows):4d} {r['mechanism']:18s} {r['status']:10s} {r['solve_s']:7.2f} s "
              f"false {r['false']} {r['claims']}", flush=True)
    cost = None if args.counts else verdict_cost()
    atomic_write_text(path, json.dumps({"meta": meta, "rows": rows, "verdict_cost": cost},
                                       indent=1))
    atomic_write_text(RESULTS / f"{name}.md", table(rows, cost, bool(args.counts)))
    print(table(rows, cost, bool(args.counts)))
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""How far below its count's promise an optimum lies, and what ranking the counts by it does.

    python benchmarks/count_promise.py [--draws 100] [--seeds 0 1] [--multi 30] [--resume]

A count's promise is the least sampled δ (more generally: the best sampled objective key) of
any design of its box's sample that assembles, every other constraint aside
(:func:`optdesign.solver.screening.promise`). A solve that ranks its counts
(:mod:`optdesign.solver.count_order`) polishes them least promise first and leaves out a count
whose promise lies more than ``MARGIN`` above the least δ found.

**The shortfall.** For each count of the shipped problems (robust ones and ``minimize:
phases`` aside) and of the random problems of ``benchmarks/oracle.py`` (``--seeds``, ``--draws``
each: a mechanism, a box of one to six decades, bounds, an objective), the count solved alone
(its verified optimum's key O) and its promise R: the shortfall (R − O) / |O|, how far the
optimum lies below what the sample promised (negative: above it), by objective (the ripple or
another) and box (of decades, a range of two decades or more, or not).

**The answers.** The problems whose solve ranks its counts: the shipped ones, and ``--multi``
random ripple problems in boxes of 0.3 to 1.9 decades with random bounds and the count free
(the four-bar 4..8, the slotted lever 3 or 5, the pulse reducer 2..4). Each is solved with the
rule and with every count polished (``MARGIN`` infinite: the same order), in one process,
after a solve that builds every count's NLPs; both answers are judged against the oracle's
checked sample of every count (``oracle.judge``: a false verdict is an ``optimal`` a checked
design beats, or an ``infeasible``/``failed`` where one is feasible).

Writes ``benchmarks/results/count_promise.{json,md}`` (each part as it ends; ``--resume`` keeps
the parts written) and ``docs/figures/count_promise.png``.
"""
from __future__ import annotations

import argparse
import json
import math
import platform
import statistics
import sys
import time
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import oracle  # noqa: E402

from optdesign.commands.files import save_figure  # noqa: E402
from optdesign.errors import ProblemError  # noqa: E402
from optdesign.evaluation.figures import forget  # noqa: E402
from optdesign.outputs.atomic import atomic_write_text  # noqa: E402
from optdesign.mechanisms import get_mechanism  # noqa: E402
from optdesign.problem.loader import load_problem  # noqa: E402
from optdesign.quantities.criteria import objective_of  # noqa: E402
from optdesign.solver import count_order, solve  # noqa: E402
from optdesign.solver.nlp import is_robust  # noqa: E402
from optdesign.solver.screening import of_decades, promise  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
#: the admissible counts a random problem of part 2 frees, per mechanism
FREE_COUNTS = {"fourbar_converter": {"lower": 4, "upper": 8},
               "slotted_lever": {"choices": [3, 5]},
               "pulse_reducer": {"lower": 2, "upper": 4}}


def quiet(function, *args):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return function(*args)


def shipped() -> list[tuple[str, object]]:
    out = []
    for path in sorted((ROOT / "problems").glob("*.yaml")):
        try:
            problem = quiet(load_problem, path)
        except ProblemError:            # an atlas's file, not a problem
            continue
        if is_robust(problem) or not problem.free_lengths() or \
                problem.objective.minimize == "phases":
            continue
        out.append((path.stem, problem))
    return out


def shortfall_rows(problems) -> list[dict]:
    """One row per count of each problem: its promise, its optimum solved alone."""
    rows = []
    for name, problem in problems:
        objective = objective_of(problem)
        for count in problem.counts():
            single = problem.with_values({problem.model.count_variable: count})
            result = quiet(solve, single)
            scored = promise(problem, count, problem.solver.screen)
            phase = result.per_phase[0]
            key = objective.result_key(phase) if phase.status == "optimal" else None
            rows.append({"name": name, "count": count, "status": phase.status,
                         "objective": problem.objective.minimize,
                         "decades": of_decades(problem), "promise": scored.promise,
                         "optimum": key,
                         "shortfall": (scored.promise - key) / abs(key)
                         if key not in (None, 0.0) and math.isfinite(scored.promise) else None})
            print(f"{name} n={count}: {phase.status} promise {scored.promise:.6g} "
                  f"optimum {key}", file=sys.stderr, flush=True)
    return rows


def random_problems(seeds, draws: int):
    for seed in seeds:
        rng = np.random.default_rng(seed)
        for i in range(draws):
            draw = oracle.random_draw(rng, i)
            try:
                yield f"oracle {seed}/{i}", quiet(oracle.build, draw)
            except Exception as exc:            # noqa: BLE001 - a draw the loader refuses
                print(f"draw {seed}/{i} left out: {exc}", file=sys.stderr)


def multi_problems(count: int, seed: int = 7):
    """Random ripple problems in boxes under two decades, the count free."""
    rng = np.random.default_rng(seed)
    made = 0
    i = 0
    while made < count:
        i += 1
        draw = oracle.random_draw(rng, 1000 + i)
        draw = replace(draw, decades=float(rng.uniform(0.3, 1.9)), objective=("ripple", False))
        key = get_mechanism(draw.mechanism).count_variable
        try:        # the oracle's problem with the count freed, read by the loader's rules
            problem = quiet(lambda: oracle.build(draw).with_design(
                **{key: FREE_COUNTS[draw.mechanism]}))
        except Exception as exc:                # noqa: BLE001
            print(f"multi {i} left out: {exc}", file=sys.stderr)
            continue
        if count_order.ranks(problem):
            made += 1
            yield f"random {i} ({draw.mechanism})", problem


def answer_rows(problems) -> list[dict]:
    rows = []
    margin = count_order.MARGIN
    for name, problem in problems:
        quiet(solve, problem)                          # every count's NLPs built
        runs = {}
        for label, m in (("ranked", margin), ("every count", math.inf), ("ranked", margin)):
            count_order.MARGIN = m
            forget()
            t0 = time.perf_counter()
            result = quiet(solve, problem)
            runs.setdefault(label, {"result": result, "times": []})["times"].append(
                time.perf_counter() - t0)
        count_order.MARGIN = margin
        found = quiet(oracle.sample, problem)
        row = {"name": name, "counts": problem.counts()}
        for label, run in runs.items():
            r = run["result"]
            row[label] = {"status": r.status, "delta": r.delta,
                          "count": int(r.design[problem.model.count_variable])
                          if r.design else None,
                          "polished": sum(p.status != count_order.OUTRANKED for p in r.per_phase),
                          "iterations": r.iterations, "seconds": min(run["times"]),
                          "false": quiet(oracle.judge, problem, r, found)}
        rows.append(row)
        a, b = row["ranked"], row["every count"]
        print(f"{name}: ranked {a['status']} {a['delta']} n={a['count']} "
              f"({a['polished']} counts, {a['seconds']:.2f} s) / every count {b['status']} "
              f"{b['delta']} n={b['count']} ({b['seconds']:.2f} s); false {a['false']} "
              f"{b['false']}", file=sys.stderr, flush=True)
    return rows


def table(data: dict) -> str:
    lines = ["A count's promise (the best sampled objective of its box's sample, constraints "
             "aside) against its optimum solved alone: the shortfall (promise − optimum) / "
             "|optimum|, positive where the optimum lies below the promise "
             "(`benchmarks/count_promise.py`).", "",
             "| objective | box | counts with an optimum | largest shortfall | median | "
             "problem of the largest |", "|---|---|---|---|---|---|"]
    rows = [r for r in data["shortfall"] if r["shortfall"] is not None]
    for ripple in (True, False):
        for decades in (False, True):
            group = [r for r in rows if (r["objective"] == "ripple") == ripple and
                     r["decades"] == decades]
            if not group:
                continue
            worst = max(group, key=lambda r: r["shortfall"])
            lines.append(f"| {'ripple' if ripple else 'another'} | "
                         f"{'of decades' if decades else 'under two decades'} | {len(group)} | "
                         f"{worst['shortfall']:+.3f} | "
                         f"{statistics.median(r['shortfall'] for r in group):+.3f} | "
                         f"{worst['name']}, n = {worst['count']} ({worst['objective']}) |")
    answers = data["answers"]
    lines += ["", f"Ranked (`MARGIN` = {data['margin']}) against every count polished, the "
                  f"same order, each answer judged against the oracle's checked sample of "
                  f"every count:", "",
              "| problem | counts | ranked: status, δ, n | counts polished | every count: "
              "status, δ, n | δ ranked / every count | time ranked / every count | false "
              "verdicts (ranked, every count) |", "|---|---|---|---|---|---|---|---|"]
    for r in answers:
        a, b = r["ranked"], r["every count"]
        ratio = (f"{a['delta'] / b['delta']:.6f}" if a["delta"] and b["delta"] else "–")
        lines.append(f"| {r['name']} | {','.join(map(str, r['counts']))} | {a['status']}, "
                     f"{_num(a['delta'])}, {a['count']} | {a['polished']} | {b['status']}, "
                     f"{_num(b['delta'])}, {b['count']} | {ratio} | "
                     f"{a['seconds'] / b['seconds']:.2f} | {len(a['false'])}, "
                     f"{len(b['false'])} |")
    if answers:
        same = sum(r["ranked"]["status"] == r["every count"]["status"] and
                   _same(r["ranked"]["delta"], r["every count"]["delta"]) for r in answers)
        times = [r["ranked"]["seconds"] / r["every count"]["seconds"] for r in answers]
        lines += ["", f"{same} of {len(answers)} answers the same (status, δ within 1e-9 "
                      f"relative); time ranked / every count: median "
                      f"{statistics.median(times):.2f}, range {min(times):.2f}–"
                      f"{max(times):.2f}; false verdicts: "
                      f"{sum(len(r['ranked']['false']) for r in answers)} ranked, "
                      f"{sum(len(r['every count']['false']) for r in answers)} every count."]
    meta = data["meta"]
    lines += ["", f"measured on {meta['machine']}, {meta['time']} (Python {meta['python']})"]
    return "\n".join(lines) + "\n"


def figure(data: dict, path: Path) -> None:
    """Each count's promise over its optimum (solved alone) against the optimum, log-log, by
    objective and box, positive keys (the least of a figure: the ripple, a peak speed, ...):
    above 1 the optimum lies below its promise; the rule leaves a count out beyond its margin."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [r for r in data["shortfall"] if r["optimum"] and r["promise"] is not None and
            math.isfinite(r["promise"]) and r["optimum"] > 0 and r["promise"] > 0]
    fig, ax = plt.subplots(figsize=(7.0, 5.4))
    groups = (("ripple, under two decades (the rule's domain)", True, False, "C0", "o"),
              ("ripple, of decades", True, True, "C1", "s"),
              ("another figure's least", False, None, "0.6", "^"))
    for label, ripple, decades, colour, marker in groups:
        group = [r for r in rows if (r["objective"] == "ripple") == ripple and
                 (decades is None or r["decades"] == decades)]
        ax.scatter([r["optimum"] for r in group], [r["promise"] / r["optimum"] for r in group],
                   s=18, c=colour, marker=marker, label=f"{label} ({len(group)})", alpha=0.8)
    ax.axhline(1.0, color="k", lw=0.8, label="promise = optimum")
    ax.axhline(1 + data["margin"], color="r", ls="--", lw=0.8,
               label=f"{1 + data['margin']:g} × the least δ found: beyond it a count is "
                     f"left out")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("the count's optimum, solved alone (its objective key)")
    ax.set_ylabel("promise / optimum")
    ax.set_title("A count's promise (the best sampled design, constraints aside) over its "
                 "optimum", fontsize=10)
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    save_figure(fig, path, dpi=110, bbox_inches=None)
    plt.close(fig)


def _num(x):
    return "–" if x is None else f"{x:.6f}"


def _same(a, b) -> bool:
    return a == b or (a is not None and b is not None and abs(a - b) <= 1e-9 * abs(b))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--draws", type=int, default=100)
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    ap.add_argument("--multi", type=int, default=30)
    ap.add_argument("--resume", action="store_true")
    args = ap.parse_args(argv)
    path = RESULTS / "count_promise.json"
    data = json.loads(path.read_text()) if args.resume and path.exists() else {}
    data["meta"] = {"time": time.strftime("%Y-%m-%d %H:%M:%S"),
                    "python": platform.python_version(),
                    "machine": f"{platform.machine()} {platform.system()}",
                    "draws": args.draws, "seeds": args.seeds, "multi": args.multi}
    data["margin"] = count_order.MARGIN

    def save():
        atomic_write_text(path, json.dumps(data, indent=1))

    if "shortfall" not in data:
        data["shortfall"] = shortfall_rows(shipped()) + \
            shortfall_rows(random_problems(args.seeds, args.draws))
        save()
    if "answers" not in data:
        ranked = [(n, p) for n, p in shipped() if count_order.ranks(p)]
        data["answers"] = answer_rows(ranked + list(multi_problems(args.multi)))
        save()
    text = table(data)
    atomic_write_text(RESULTS / "count_promise.md", text)
    figure(data, ROOT / "docs" / "figures" / "count_promise.png")
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

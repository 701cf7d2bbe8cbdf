"""Does `optimal` survive a denser screening of the same box? The oracle's random problems,
each solved as shipped and with ``--factor`` times the screened designs.

A solve screens ``solver.screen`` designs of the box (8 times as many where a range spans two
decades or more), clusters them into basins and polishes the best few with IPOPT; its
``optimal`` is the best basin it polished. The verdicts' oracle (``benchmarks/
solve_oracle.py``) sets each verdict beside a brute-force sample of the box, judged exactly,
which an unpolished sample seldom beats. This asks a harder question of the same problems
(the same draws: ``--problems``, ``--seed``): the solve again with ``solver.screen`` times
``--factor``, the two answers compared on the problem's own objective (the exact key of
each: lower is better), in two processes at once (one per core). An answer of the denser
solve that is better is a design the shipped solve's ``optimal`` did not know of.

    python benchmarks/solve_denser.py [--problems 300] [--seed 0] [--factor 4]
        [--mechanisms fourbar_converter slotted_lever pulse_reducer] [--resume]

Writes benchmarks/results/solve_denser.md and .json (each mode's rows also in
``solve_denser_<mode>.json`` as they come: ``--resume`` goes on from them).
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from solve_perturbation import (MOVED, answer_rows, compare, in_two_processes,  # noqa: E402
                                moved_lines, summary_lines, write_results)

RESULTS = ROOT / "benchmarks" / "results"
MODES = ("shipped", "denser")
MECHANISMS = ("fourbar_converter", "slotted_lever", "pulse_reducer")


def mode_rows(mode: str, args, path: Path) -> None:
    """Solve the draws of ``args`` of its mechanisms in ``mode`` (:func:`answer_rows`)."""
    import numpy as np

    import oracle

    rng = np.random.default_rng(args.seed)
    draws = [d for d in (oracle.random_draw(rng, i) for i in range(args.problems))
             if d.mechanism in args.mechanisms]

    def denser(problem):
        return dataclasses.replace(problem, solver=dataclasses.replace(
            problem.solver, screen=args.factor * problem.solver.screen))

    answer_rows(mode, draws, path, denser if mode == "denser" else None)


def table(summary: list[dict], moved: list[dict], rows: dict, factor: int) -> str:
    time_of = {m: sum(r["solve_s"] for r in rows[m]) for m in MODES}
    lines = [f"The solve's answer on the problems of the verdicts' oracle, as shipped and with "
             f"{factor} times the screened designs: an answer moved when its objective moved "
             f"by more than {MOVED:g} (relative); better or worse for the denser screening. "
             f"Time of all solves: {time_of['shipped']:.0f} s shipped, "
             f"{time_of['denser']:.0f} s denser.", ""]
    lines += summary_lines(summary) + [""] + moved_lines(moved, "denser", 20)
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--problems", type=int, default=300)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--factor", type=int, default=4)
    ap.add_argument("--mechanisms", nargs="+", choices=MECHANISMS, default=list(MECHANISMS))
    ap.add_argument("--resume", action="store_true")
    ap.add_argument("--_mode", choices=MODES, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if not 1 <= args.problems <= 10_000 or not 2 <= args.factor <= 64:
        ap.error("--problems must be 1 to 10000 and --factor 2 to 64")
    paths = {m: RESULTS / f"solve_denser_{m}.json" for m in MODES}
    if args._mode:
        mode_rows(args._mode, args, paths[args._mode])
        return 0
    if not args.resume:
        for path in paths.values():
            path.unlink(missing_ok=True)
    if not in_two_processes(__file__, MODES, [
            "--problems", str(args.problems), "--seed", str(args.seed), "--factor",
            str(args.factor), "--mechanisms", *args.mechanisms]):
        print("a mode's solves failed", file=sys.stderr)
        return 1
    rows = {m: json.loads(p.read_text()) for m, p in paths.items()}
    summary, moved = compare(rows["shipped"], rows["denser"])
    write_results("solve_denser",
                  {"seed": args.seed, "problems": args.problems, "factor": args.factor,
                   "mechanisms": args.mechanisms},
                  {"summary": summary, "moved": moved}, table(summary, moved, rows, args.factor))
    return 0


if __name__ == "__main__":
    sys.exit(main())

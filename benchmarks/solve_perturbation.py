"""What a quarter of IPOPT's time would cost: the answers of random problems when IPOPT's
linear algebra changes in its last bits.

Once the NLP's derivatives are compiled, most of an IPOPT run on our small NLPs is IPOPT's own
linear algebra. Two of its options cost time on every iteration: MUMPS's scaling, computed
anew at every factorisation (``mumps_scaling``, ``mumps_permuting_scaling``), and the residual
check of every step (``fast_step_computation``). Switched off (:data:`PERTURBED`), a run takes
the same iterations to the same optimum (the objective equal to 1e-15) in about three quarters
of the time; but every step differs in its last bits, and a multistart solve is a chain of
decisions on where runs end (which basin, stopped or not, refined or not). This measures both
sides:

* **the floor runs**: per problem of the race (``benchmarks/solve_vs_peers.py``'s ``CASES``)
  and count, one IPOPT run from the winning start on the compiled library, with the options
  as shipped and perturbed, in turn ``--rounds`` times in one process (medians);
* **the answers**: the random problems of ``benchmarks/solve_oracle.py`` (the same draws:
  ``--problems``, ``--seed``), each solved with the options as shipped and perturbed, in two
  processes at once (one per core), and the two answers compared on the problem's own
  objective (the exact key of each answer): moved (beyond 1e-6 relative), better, worse, and
  the statuses that changed.

    python benchmarks/solve_perturbation.py [--problems 300] [--seed 0] [--rounds 9] [--resume]

Writes benchmarks/results/solve_perturbation.md and .json (each mode's rows also in
``solve_perturbation_<mode>.json`` as they come: ``--resume`` goes on from them).
"""
from __future__ import annotations

import argparse
import json
import math
import os
import platform
import statistics
import subprocess
import sys
import time
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from optdesign.outputs.atomic import atomic_write_text  # noqa: E402

RESULTS = ROOT / "benchmarks" / "results"
#: the options switched off (IPOPT's defaults are 77, 7 and "no")
PERTURBED = {"ipopt.mumps_scaling": 0, "ipopt.mumps_permuting_scaling": 0,
             "ipopt.fast_step_computation": "yes"}
MODES = {"shipped": {}, "perturbed": PERTURBED}
#: two answers differ when their objective keys differ by more than this (relative)
MOVED = 1e-6


# --------------------------------------------------------------------------- the floor runs
def floor_run(problem, phase):
    """(the NLP, its IPOPT arguments from ``phase``'s winning start, its count): the run
    ``benchmarks/solve_floor.py`` times."""
    from optdesign.solver.phase_solver import PhaseSolver
    from solve_floor import winning_start

    count, start, _ = winning_start(problem, phase)
    solver = PhaseSolver(problem, count)
    nlp, args = solver.ipopt_arguments(problem, solver.verify(problem, start, search=False))
    return nlp, args, count


def floor_rows(rounds: int) -> list[dict]:
    """Per race problem and optimal count: the winning start's IPOPT run both ways."""
    import casadi as ca

    from optdesign.solver import compiled
    from optdesign.solver.driver import solve
    from optdesign.solver.nlp import IPOPT_OPTIONS
    from solve_vs_peers import CASES, load_case

    rows = []
    for case in CASES:
        problem = load_case(case)
        result = solve(problem)
        for phase in (p for p in result.per_phase if p.status == "optimal"):
            nlp, args, count = floor_run(problem, phase)
            hessian = problem.solver.hessian
            rec = compiled.recipe(nlp.x_sym, nlp.p_sym, nlp.f, nlp.g, hessian)
            where = compiled.folder()
            path = compiled.library(rec, where) if where is not None else None
            source = str(path) if path is not None else \
                {"x": nlp.x_sym, "p": nlp.p_sym, "f": nlp.f, "g": nlp.g}
            shipped = dict(IPOPT_OPTIONS) | {"ipopt.max_iter": problem.solver.max_iter,
                                             "ipopt.hessian_approximation": hessian}
            solvers = {mode: ca.nlpsol(f"floor_{mode}", "ipopt", source, shipped | extra)
                       for mode, extra in MODES.items()}
            times, ends = {m: [] for m in MODES}, {}
            for _ in range(rounds):
                for mode, s in solvers.items():
                    t0 = time.perf_counter()
                    sol = s(**args)
                    times[mode].append(time.perf_counter() - t0)
                    ends[mode] = (int(s.stats()["iter_count"]), float(sol["f"]))
            med = {m: statistics.median(v) for m, v in times.items()}
            rows.append({"case": case, "count": count, "compiled": path is not None,
                         "shipped_ms": 1e3 * med["shipped"],
                         "perturbed_ms": 1e3 * med["perturbed"],
                         "ratio": med["perturbed"] / med["shipped"],
                         "iterations": [ends[m][0] for m in MODES],
                         "objective_difference": ends["perturbed"][1] - ends["shipped"][1]})
            print(f"floor {case} n={count}: {rows[-1]['ratio']:.2f}", flush=True)
    return rows


# --------------------------------------------------------------------------- the answers
def mode_rows(mode: str, problems: int, seed: int, path: Path) -> None:
    """Solve the oracle's draws with ``mode``'s options (:func:`answer_rows`)."""
    import numpy as np

    import oracle
    from optdesign.solver import nlp as nlp_module

    nlp_module.IPOPT_OPTIONS.update(MODES[mode])
    rng = np.random.default_rng(seed)
    answer_rows(mode, [oracle.random_draw(rng, i) for i in range(problems)], path)


def answer_rows(label: str, draws, path: Path, prepare=None, build=None) -> None:
    """Solve each of the oracle's ``draws`` (its problem made by ``build``, default
    ``oracle.build``, and passed through ``prepare`` first, where given), a row per problem
    (the exact key of the answer: lower is better) appended to ``path`` as it comes; the rows
    there already are kept, their draws not solved again.
    ``converged``: the polishes that converged to a design meeting every constraint, over
    the counts (0: the answer is a design where a polish stopped, or a screened one)."""
    import oracle
    from optdesign.solver import solve, verify
    from optdesign.solver.phase_solver import SUCCESS

    rows = json.loads(path.read_text()) if path.exists() else []
    for draw in draws[len(rows):]:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            problem = (build or oracle.build)(draw)
            if prepare is not None:
                problem = prepare(problem)
            t0 = time.perf_counter()
            result = solve(problem)
            seconds = time.perf_counter() - t0
            key = float(verify(problem, result.design).key) if result.design else None
        rows.append({"seed": draw.seed, "mechanism": draw.mechanism,
                     "objective": problem.objective.minimize, "decades": draw.decades,
                     "status": result.status, "key": key, "iterations": result.iterations,
                     "solve_s": seconds,
                     "converged": sum(1 for phase in result.per_phase for r in phase.starts
                                      if r.feasible and r.ipopt_status in SUCCESS)})
        atomic_write_text(path, json.dumps(rows, indent=1))
        print(f"{label} {len(rows):4d} {result.status}", flush=True)


def solving_env() -> dict:
    """The environment of a process that solves the oracle's draws: no warm server, the
    compiled derivatives loaded where cached (``OPTDESIGN_COMPILE``, ``load`` unless set)."""
    return dict(os.environ, OPTDESIGN_SERVER="off",
                OPTDESIGN_COMPILE=os.environ.get("OPTDESIGN_COMPILE", "load"))


def in_two_processes(script: str, modes, arguments: list[str]) -> bool:
    """``script --_mode M *arguments`` for each mode, all at once (one per core); whether
    every one ended well."""
    env = solving_env()
    children = [subprocess.Popen([sys.executable, script, "--_mode", m, *arguments], env=env)
                for m in modes]
    return all([c.wait() == 0 for c in children])


def summary_lines(summary: list[dict]) -> list[str]:
    """The table of :func:`compare`'s counts, per mechanism and for all."""
    lines = ["| mechanism | problems | answers moved | better | worse | status changed |",
             "|---|---|---|---|---|---|"]
    for s in summary:
        lines.append(f"| {s['mechanism']} | {s['problems']} | {s['moved']} | {s['better']} | "
                     f"{s['worse']} | {s['status_changed']} |")
    return lines


def moved_lines(moved: list[dict], other: str, most: int, first: str = "shipped") -> list[str]:
    """The table of the answers that moved (the first ``most``), the first solve's column
    named ``first``, the second's ``other``."""
    lines = [f"| problem | mechanism | objective | box [decades] | {first} | {other} | change |",
             "|---|---|---|---|---|---|---|"]
    for r in moved[:most]:
        change = "status: " + r["status"] + " → " + r["perturbed_status"] \
            if math.isnan(r["change"]) else f"{r['change']:+.1%}"
        shipped = "–" if r["shipped"] is None else f"{r['shipped']:.6g}"
        second = "–" if r["perturbed"] is None else f"{r['perturbed']:.6g}"
        lines.append(f"| {r['seed']} | {r['mechanism']} | {r['objective']} | "
                     f"{r['decades']:.1f} | {shipped} | {second} | {change} |")
    return lines


def compare(shipped: list[dict], perturbed: list[dict]) -> tuple[list[dict], list[dict]]:
    """(per mechanism and all: problems, moved, better, worse, status changed; the problems
    whose answer moved or whose status changed, largest move first)."""
    moved = []
    for a, b in zip(shipped, perturbed):
        if a["status"] != b["status"]:
            moved.append({**a, "shipped": a["key"], "perturbed": b["key"],
                          "perturbed_status": b["status"], "change": math.nan})
            continue
        if a["key"] is None or b["key"] is None:
            continue
        change = (b["key"] - a["key"]) / max(abs(a["key"]), 1e-12)
        if abs(change) > MOVED:
            moved.append({**a, "shipped": a["key"], "perturbed": b["key"],
                          "perturbed_status": b["status"], "change": change})
    summary = []
    for mechanism in sorted({r["mechanism"] for r in shipped}) + ["all"]:
        mine = [r for r in moved if mechanism in ("all", r["mechanism"])]
        n = sum(1 for r in shipped if mechanism in ("all", r["mechanism"]))
        summary.append({"mechanism": mechanism, "problems": n,
                        "moved": sum(1 for r in mine if not math.isnan(r["change"])),
                        "better": sum(1 for r in mine if r["change"] < 0),
                        "worse": sum(1 for r in mine if r["change"] > 0),
                        "status_changed": sum(1 for r in mine if math.isnan(r["change"]))})
    moved.sort(key=lambda r: -abs(r["change"]) if not math.isnan(r["change"]) else -math.inf)
    return summary, moved


def table(floors: list[dict], summary: list[dict], moved: list[dict], rounds: int) -> str:
    lines = [
        f"The race's floor runs (the winning start's IPOPT run, compiled), IPOPT's MUMPS "
        f"scaling and step residual check as shipped and switched off, in turn, {rounds} "
        f"rounds in one process; medians.", "",
        "| problem | count | shipped [ms] | switched off [ms] | off / shipped | iterations "
        "(shipped, off) | objective, off − shipped |",
        "|---|---|---|---|---|---|---|"]
    for r in floors:
        lines.append(f"| {r['case']} | {r['count']} | {r['shipped_ms']:.1f} | "
                     f"{r['perturbed_ms']:.1f} | {r['ratio']:.2f} | {r['iterations'][0]}, "
                     f"{r['iterations'][1]} | {r['objective_difference']:+.1e} |")
    lines += ["", "The solve's answer, on the problems of the verdicts' oracle, with the two "
              f"options as shipped and switched off: an answer moved when its objective moved "
              f"by more than {MOVED:g} (relative); better or worse for the switched-off solve.",
              ""] + summary_lines(summary)
    lines += [""] + moved_lines(moved, "switched off", 12)
    return "\n".join(lines) + "\n"


def write_results(name: str, settings: dict, document: dict, text: str,
                  when: str | None = None) -> None:
    """``benchmarks/results/<name>.json`` (``meta``: when (now, or ``when``: the tables of a
    run written again), on what, and ``settings``; then ``document``) and ``<name>.md``
    (``text``), each written atomically; ``text`` printed. The oracle's A/B benchmarks (this
    one, solve_denser, solve_answers_ab) end alike."""
    meta = {"time": when or time.strftime("%Y-%m-%d %H:%M:%S"),
            "python": platform.python_version(),
            "machine": f"{platform.machine()} {platform.system()}"} | settings
    atomic_write_text(RESULTS / f"{name}.json",
                      json.dumps({"meta": meta} | document, indent=1))
    atomic_write_text(RESULTS / f"{name}.md", text)
    print(text)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--problems", type=int, default=300)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--rounds", type=int, default=9)
    ap.add_argument("--resume", action="store_true")
    ap.add_argument("--_mode", choices=list(MODES), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.problems < 1 or args.rounds < 1:
        ap.error("--problems and --rounds must be at least 1")
    paths = {m: RESULTS / f"solve_perturbation_{m}.json" for m in MODES}
    if args._mode:
        mode_rows(args._mode, args.problems, args.seed, paths[args._mode])
        return 0
    if not args.resume:
        for path in paths.values():
            path.unlink(missing_ok=True)
    if not in_two_processes(__file__, MODES, ["--problems", str(args.problems), "--seed",
                                              str(args.seed)]):
        print("a mode's solves failed", file=sys.stderr)
        return 1
    floors = floor_rows(args.rounds)
    rows = {m: json.loads(p.read_text()) for m, p in paths.items()}
    summary, moved = compare(rows["shipped"], rows["perturbed"])
    write_results("solve_perturbation",
                  {"seed": args.seed, "problems": args.problems, "rounds": args.rounds},
                  {"floors": floors, "summary": summary, "moved": moved},
                  table(floors, summary, moved, args.rounds))
    return 0


if __name__ == "__main__":
    sys.exit(main())

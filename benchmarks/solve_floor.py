"""The solve against its floor: what one IPOPT run from the winning start costs, and ours.

Per problem of the race (``benchmarks/solve_vs_peers.py``'s ``CASES``):

* **the floor**: one IPOPT run from the start whose polish won (the NLP built beforehand, its
  derivatives compiled, :mod:`optdesign.solver.compiled`), plus one exact check of the answer
  (``verify``, the evaluator's cache emptied): what a solver that knew the winning start and
  still verified its answer would spend; the median of ``--repeats``, measured in each
  process after each warm solve (each ratio to it the median of each process's own:
  :func:`paired_ratios`); where the problem
  has several admissible counts, also the floor of every count its solve found an optimum
  for, summed (each count's own winning run and check): a solve that must show each count's
  optimum (``per_phase``) cannot spend less;
* **our first solve**: ``solve(problem)`` in a fresh process (imports done, the clock around
  the call alone) with the NLP's compiled library in the cache; the solver's imports
  (``optdesign.solver.driver``: CasADi's and scipy.optimize's above all), which a solve
  pays once per process, measured on their own just before it;
* **our warm solve**: the next ``--repeats`` calls in that process (medians), each made after
  the evaluator's memory of the designs it checked is emptied
  (:func:`optdesign.evaluation.figures.forget`): a warm process solving a problem whose
  designs it has not checked yet, not one repeating its answers; each stage of it
  (``timings_s``: the NLP's build, the screening, the IPOPT runs, the exact verification,
  each summed over the solve's processes, and of these the seconds spent in a process beside
  the solve's own at the same time (``beside``: the best basins polished at once); the rest
  is the sensitivities, the accuracy record, the bookkeeping and the solving process's wait
  for a polish beside it to end), the IPOPT iterations
  of the winning run against all of the solve's, and the CPU seconds of every process of
  the warm solve (the solving one's and those it forked, each waited for as it exits, so
  the next warm solve no longer begins beside the last one's exiting processes)
  against the floor, which runs on one core: on two cores the warm solve is at least half
  that ratio times the floor, however its work is laid out;
* **the same solve again**: one more call with that memory kept, as a notebook that solves
  the same file twice runs it (the exact checks of the designs the solve before checked are
  read from it);
* **before and after**: the same in processes on CasADi's virtual machine
  (``OPTDESIGN_COMPILE=off``), a virtual-machine process and a compiled one alternating for
  each problem in each of ``--rounds`` rounds, so both meet the same machine; "same answer"
  compares δ, the design and the status bit for bit.

Before measuring, the race's NLPs are compiled into the user's cache (``optdesign warm-up``'s
recipes, then one solve that starts a build of any NLP the warm-up did not foresee, waited
for); ``--no-warm-up`` skips that.

    python benchmarks/solve_floor.py [--problems disc_n6 ...] [--rounds 5] [--repeats 3]

Writes benchmarks/results/solve_floor.md (three tables: the floor, where the warm solve
goes, compiled against the virtual machine) and solve_floor.json.
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
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from optdesign.outputs.atomic import atomic_write_text  # noqa: E402
from solve_vs_peers import (CASES, cpu_seconds, load_case, one_check_seconds,  # noqa: E402
                            timed_solve)

RESULTS = ROOT / "benchmarks" / "results"
STAGES = ("build", "screening", "ipopt", "verification")
MODES = {"vm": "off", "compiled": "load"}
#: rounds of the race's solves the warm-up runs at most (each starts the builds it misses)
WARM_UP_ROUNDS = 6


# --------------------------------------------------------------------------- in the child
def winning_start(problem, phase):
    """(count, start values, its StartRecord) of the polish that gave the answer of
    ``phase`` (a PhaseResult with a verified optimum)."""
    count = phase.count
    records = [s for s in phase.starts if s.feasible and s.delta is not None]
    win = min(records, key=lambda s: abs(s.delta - phase.delta))
    return count, dict(win.start) | {problem.model.count_variable: count}, win


def answer_phase(problem, result):
    """The PhaseResult of ``result``'s answer (its count's)."""
    count = int(result.design[problem.model.count_variable])
    return next(p for p in result.per_phase if p.count == count)


def floor(problem, phase, repeats: int) -> dict:
    """One IPOPT run from ``phase``'s winning start on the NLP built beforehand, and one
    exact check of where it ends: seconds of each (medians of ``repeats``), its
    iterations."""
    from optdesign.solver.phase_solver import AS_IT_IS, PhaseSolver

    count, start, win = winning_start(problem, phase)
    solver = PhaseSolver(problem, count)
    hessian = problem.solver.hessian
    ver = solver.verify(problem, start, search=False)
    design, runs = dict(start), []
    if win.ipopt_status != AS_IT_IS:
        solver.nlp(ver.sequences).solver(hessian)          # built beforehand
        for _ in range(repeats):
            t0 = time.perf_counter()
            run = solver._ipopt(problem, ver, 0.0, hessian)
            runs.append((time.perf_counter() - t0, run.iterations))
        design = start | run.lengths
    check = one_check_seconds(problem, design, repeats)
    ipopt = statistics.median(t for t, _ in runs) if runs else 0.0
    return {"ipopt_s": ipopt, "check_s": check, "floor_s": ipopt + check,
            "iterations": runs[0][1] if runs else 0, "winning_run_iterations": win.iterations,
            "winning_status": win.ipopt_status}


def child(case: str, repeats: int) -> dict:
    """One process's measures of ``case``: the first solve, ``repeats`` warm ones, the floor;
    and how many of the NLPs it built ran on a compiled library."""
    from optdesign.solver import compiled

    loaded, real, real_of = [], compiled.library, compiled.nlpsol_of

    def library(rec, where):            # an NLP built from its graph that finds no library
        path = real(rec, where)
        if path is None:
            loaded.append(False)
        return path

    def nlpsol_of(name, path, opts):    # IPOPT on a library (from the graph or the record)
        loaded.append(True)
        return real_of(name, path, opts)

    compiled.library, compiled.nlpsol_of = library, nlpsol_of
    problem = load_case(case)
    t0 = time.perf_counter()
    import optdesign.solver.driver  # noqa: F401  (what a solve imports at its first call)
    imports = time.perf_counter() - t0
    from optdesign.evaluation.figures import forget

    result, first = timed_solve(problem)
    answer = answer_phase(problem, result)
    # each warm solve followed by a floor of its own, so a ratio compares two measures
    # seconds apart (paired_ratios): the machine's speed drifts
    warm, floors = [], []
    for _ in range(repeats):
        forget()
        cpu0 = cpu_seconds()
        warm.append(timed_solve(problem)[1])
        reaped()
        warm[-1]["cpu_every_process_s"] = cpu_seconds() - cpu0
        floors.append(floor(problem, answer, repeats))
    again = timed_solve(problem)[1]             # the memory of the solve before kept
    # a solve of several counts polishes each: the floor of each count's own winning run
    each = [floor(problem, p, repeats)["floor_s"] if p is not answer else None
            for p in result.per_phase if p.status == "optimal"]
    mine = {k: statistics.median(f[k] for f in floors) if isinstance(floors[0][k], float)
            else floors[0][k] for k in floors[0]}
    for w, f in zip(warm, floors):
        w["floor_s"] = f["floor_s"]
    return {"first": first, "warm": warm, "again": again, "floor": mine,
            "floor_every_count_s": sum(mine["floor_s"] if f is None else f for f in each),
            "optimal_counts": len(each),
            "imports_s": imports,
            "mode": compiled.mode(), "compiled_nlps": sum(loaded), "nlps": len(loaded)}


def reaped(most_s: float = 10.0) -> None:
    """Wait (up to ``most_s``) for the processes a solve forked beside itself to end, so that
    their CPU seconds count in this process's children's (``resource.RUSAGE_CHILDREN``): a
    solve does not wait for a process that has sent its answer as it exits. A child kept
    for the next solve's polishes (optdesign/kept_children.py) is not waited for: its CPU
    seconds are read where it runs (``cpu_seconds``)."""
    import multiprocessing

    from optdesign import kept_children

    end = time.perf_counter() + most_s
    while time.perf_counter() < end and any(
            p.pid not in kept_children.pids() for p in multiprocessing.active_children()):
        time.sleep(0.001)


def run_child(case: str, mode: str, repeats: int) -> dict:
    env = dict(os.environ, OPTDESIGN_COMPILE=MODES[mode], OPTDESIGN_SERVER="off")
    out = subprocess.run([sys.executable, __file__, "--_child", case, "--repeats", str(repeats)],
                         capture_output=True, text=True, env=env, cwd=ROOT)
    line = next((x for x in out.stdout.splitlines() if x.startswith("@@FLOOR@@")), None)
    if line is None:
        raise RuntimeError(f"{case} ({mode}) failed:\n{out.stderr[-3000:]}")
    return json.loads(line[len("@@FLOOR@@"):])


# --------------------------------------------------------------------------- warm-up
def warm_up(cases, log) -> None:
    """Compile every NLP the race's solves build, and every function they run on lanes, into
    the user's cache, and wait for it: the warm-up's libraries first, then the race's solves
    (each starting the builds of what it found missing) until a round adds none."""
    from optdesign.commands.warmup import lanes_recipes_of, recipes_of
    from optdesign.limits import local_processes
    from optdesign.solver import compiled

    where = compiled.folder()
    if where is None or compiled.compiler() is None:
        log("no cache folder or no C compiler: measured on the virtual machine")
        return
    for case in cases:
        problem = load_case(case)
        recipes = [r for _, r in recipes_of(problem) + lanes_recipes_of(problem)]
        for rec, path, seconds, note in compiled.warm_up(recipes, where, local_processes(0)):
            log(f"{case}: {path} ({note}, {seconds:.1f} s)")
    env = dict(os.environ, OPTDESIGN_COMPILE="on", OPTDESIGN_SERVER="off")
    code = "import sys; from solve_vs_peers import load_case; from optdesign.solver import " \
           "solve; [solve(load_case(c)) for c in sys.argv[1:]]"
    for _ in range(WARM_UP_ROUNDS):
        before = sorted(where.glob("*.so"))
        subprocess.run([sys.executable, "-c", code, *cases], env=env, check=True,
                       cwd=ROOT / "benchmarks")
        while compiled.builds_under_way(where):        # the NLPs' and the lanes' builds
            time.sleep(1.0)
        if sorted(where.glob("*.so")) == before:
            return
    log(f"libraries still built after {WARM_UP_ROUNDS} rounds of the race's solves")


# --------------------------------------------------------------------------- output
def summary(runs: list[dict]) -> dict:
    """Medians over the rounds of one (case, mode)."""
    warm = [w for r in runs for w in r["warm"]]
    return {"first_s": statistics.median(r["first"]["time_s"] for r in runs),
            "warm_s": statistics.median(w["time_s"] for w in warm),
            "again_s": statistics.median(r["again"]["time_s"] for r in runs),
            "stages_s": {k: statistics.median(w["timings"][k] for w in warm) for k in STAGES},
            "beside_s": statistics.median(w["timings"].get("beside", 0.0) for w in warm),
            "cpu_s": statistics.median(w.get("cpu_every_process_s", math.nan) for w in warm),
            "floor_s": statistics.median(r["floor"]["floor_s"] for r in runs),
            "floor_every_count_s": statistics.median(
                r.get("floor_every_count_s", r["floor"]["floor_s"]) for r in runs),
            "optimal_counts": runs[0].get("optimal_counts", 1),
            "imports_s": statistics.median(r.get("imports_s", math.nan) for r in runs),
            "floor_ipopt_s": statistics.median(r["floor"]["ipopt_s"] for r in runs),
            "floor_check_s": statistics.median(r["floor"]["check_s"] for r in runs),
            "iterations": runs[0]["warm"][0]["iterations"],
            "winning_iterations": runs[0]["floor"]["winning_run_iterations"],
            "compiled_nlps": min(r["compiled_nlps"] for r in runs),
            "nlps": max(r["nlps"] for r in runs)} | paired_ratios(runs)


def paired_ratios(runs: list[dict]) -> dict:
    """Each ratio to a floor as the median over the rounds of each process's own: its first
    solve over its floor, and the median of its warm solves each over the floor measured
    right after it; to the answer's count's floor, and to every count's summed (the other
    counts' floors measured once per process). The machine's speed drifts (on a shared one,
    by up to a factor of two within minutes): a ratio of medians taken minutes apart moves
    with it, one of two measures seconds apart much less."""
    def ratios(r):
        answer = r["floor"]["floor_s"]
        others = r.get("floor_every_count_s", answer) - answer
        warm = [(w["time_s"], w.get("floor_s", answer)) for w in r["warm"]]
        return {"first_over_answer": r["first"]["time_s"] / answer,
                "first_over_every": r["first"]["time_s"] / (answer + others),
                "warm_over_answer": statistics.median(t / f for t, f in warm),
                "warm_over_every": statistics.median(t / (f + others) for t, f in warm)}

    each = [ratios(r) for r in runs]
    return {k: statistics.median(e[k] for e in each) for k in each[0]}


def same_answer(a: list[dict], b: list[dict]) -> bool:
    """Every solve of both lists with the same status, δ and design, bit for bit."""
    answers = {json.dumps([s["status"], s["delta"], s["design"]], sort_keys=True)
               for r in a + b for s in [r["first"], *r["warm"], r["again"]]}
    return len(answers) == 1


def tables(results: dict) -> str:
    lines = ["| problem | floor [ms] | warm solve [s] | warm / floor | first solve [s] | "
             "first / floor | the solver's imports, once per process [s] | counts solved: "
             "the floor of each, summed [ms] | warm / that floor | first / that floor | the same "
             "solve again [s] |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for case, r in results.items():
        c = r["compiled"]
        every = c.get("floor_every_count_s", c["floor_s"])
        counts = c.get("optimal_counts", 1)
        lines.append(f"| {case} | {1e3 * c['floor_s']:.0f} | {c['warm_s']:.3f} | "
                     f"{c['warm_over_answer']:.1f}× | {c['first_s']:.3f} | "
                     f"{c['first_over_answer']:.1f}× | {c.get('imports_s', math.nan):.2f} | "
                     + (f"{counts}: {1e3 * every:.0f} | {c['warm_over_every']:.1f}× | "
                        f"{c['first_over_every']:.1f}× |"
                        if counts > 1 else "1 | – | – |") + f" {c['again_s']:.3f} |")
    lines += ["", "| problem | floor: IPOPT + check [ms] | build | screening | IPOPT | "
              "verification | of these, in a process beside the solve's | rest | IPOPT "
              "iterations: winning run / solve | CPU of every process [ms] | CPU / floor |",
              "|---|---|---|---|---|---|---|---|---|---|---|"]
    for case, r in results.items():
        c = r["compiled"]
        stages = [1e3 * c["stages_s"][k] for k in STAGES]
        beside = 1e3 * c.get("beside_s", 0.0)
        rest = 1e3 * c["warm_s"] - (sum(stages) - beside)
        lines.append(f"| {case} | {1e3 * c['floor_ipopt_s']:.0f} + "
                     f"{1e3 * c['floor_check_s']:.0f} | "
                     + " | ".join(f"{s:.0f}" for s in stages) + f" | {beside:.0f} | {rest:.0f} | "
                     f"{c['winning_iterations']} / {c['iterations']} | "
                     f"{1e3 * c.get('cpu_s', math.nan):.0f} | "
                     f"{c.get('cpu_s', math.nan) / c['floor_s']:.1f}× |")
    lines += ["", "| problem | warm, virtual machine [s] | warm, compiled [s] | VM / compiled "
              "| first, virtual machine [s] | first, compiled [s] | floor, VM [ms] | NLPs on a "
              "library (main process) | same answer |", "|---|---|---|---|---|---|---|---|---|"]
    for case, r in results.items():
        v, c = r["vm"], r["compiled"]
        lines.append(f"| {case} | {v['warm_s']:.3f} | {c['warm_s']:.3f} | "
                     f"{v['warm_s'] / c['warm_s']:.2f} | {v['first_s']:.3f} | "
                     f"{c['first_s']:.3f} | {1e3 * v['floor_s']:.0f} | "
                     f"{c['compiled_nlps']} of {c['nlps']} | "
                     f"{'yes' if r['same_answer'] else 'no'} |")
    return "\n".join(lines)


def header(args: dict) -> str:
    return (f"Our solve against its floor (one IPOPT run from the winning start, the NLP "
            f"built and compiled, plus one exact check), in-process, medians of "
            f"{args['rounds']} fresh processes per mode × {args['repeats']} warm solves, each "
            f"after the evaluator's memory of checked designs is emptied (the same solve again "
            f"keeps it); the virtual machine's and the compiled processes alternating. Each "
            f"ratio to a floor is the median of each process's own (its solves over the floor "
            f"it measured), not the quotient of the columns' medians.\n\n")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--problems", nargs="+", choices=list(CASES), default=list(CASES))
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--repeats", type=int, default=3,
                        help="warm solves (and floor runs) per process")
    parser.add_argument("--no-warm-up", action="store_true",
                        help="measure with the cache as it is")
    parser.add_argument("--render", action="store_true",
                        help="only rewrite the .md from the .json of the last run")
    parser.add_argument("--_child", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.render:
        saved = json.loads((RESULTS / "solve_floor.json").read_text())
        atomic_write_text(RESULTS / "solve_floor.md", header(saved["meta"]["args"])
                          + tables(saved["results"]) + "\n")
        return 0
    if args._child:
        print("@@FLOOR@@" + json.dumps(child(args._child, args.repeats), default=float))
        return 0
    log = lambda s: print(s, file=sys.stderr, flush=True)  # noqa: E731
    if not args.no_warm_up:
        warm_up(args.problems, log)
    runs = {(c, m): [] for c in args.problems for m in MODES}
    for k in range(args.rounds):
        for case in args.problems:
            for mode in MODES:                 # the virtual machine, then compiled
                runs[(case, mode)].append(run_child(case, mode, args.repeats))
                log(f"round {k + 1}: {case} {mode}: warm "
                    f"{runs[(case, mode)][-1]['warm'][0]['time_s']:.3f} s")
    results = {c: {m: summary(runs[(c, m)]) for m in MODES} |
               {"same_answer": same_answer(runs[(c, "vm")], runs[(c, "compiled")])}
               for c in args.problems}
    md = header(vars(args)) + tables(results) + "\n"
    print(md)
    meta = {"args": {k: v for k, v in vars(args).items() if k != "_child"},
            "time": time.strftime("%Y-%m-%d %H:%M:%S"), "python": platform.python_version(),
            "machine": f"{platform.machine()} {platform.system()}", "cores": os.cpu_count()}
    atomic_write_text(RESULTS / "solve_floor.md", md)
    atomic_write_text(RESULTS / "solve_floor.json", json.dumps(
        {"meta": meta, "results": results,
         "runs": {f"{c} {m}": v for (c, m), v in runs.items()}}, indent=1, default=float))
    log(f"wrote {RESULTS / 'solve_floor.md'} and .json")
    return 0


if __name__ == "__main__":
    sys.exit(main())

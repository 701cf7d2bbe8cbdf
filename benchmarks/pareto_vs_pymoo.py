"""The ε-constraint sweep (``optdesign pareto``) against pymoo's NSGA-II on the same problem.

Same model: NSGA-II's objectives are the exact evaluator's (``optdesign.solve.verify``): δ
(worst over the listed eccentricities) and -ratio; its constraint is the summed violation of
the same constraints (assembly, transmission angle, pin radius, ratio bound), so only designs
that ``verify`` passes count as feasible. The phase count is one more variable, mapped from
[0, len(counts)) to the admissible counts. NSGA-II runs on as many processes as the sweep,
for ``--factor`` times the sweep's wall time.

Hypervolume for both, against time, with one common normalisation: ideal and nadir of the
non-dominated union of both final fronts, reference point (1.1, 1.1) in normalised space.

    PYTHONPATH=. python benchmarks/pareto_vs_pymoo.py [problems/pareto_fourbar.yaml]
        [--out results/bench_pareto] [--workers 2] [--factor 10] [--ours DIR]

Writes OUT/bench.md (the table), OUT/hv_vs_time.png, OUT/fronts.png and OUT/bench.json.
"""
from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from optdesign.errors import OptDesignError  # noqa: E402
from optdesign.pareto.indicators import (hypervolume_2d, non_dominated,  # noqa: E402
                                         normalise, objectives)
from optdesign.problem import load_problem  # noqa: E402
from optdesign.solve import verify  # noqa: E402

PROBLEM = None


def _init(path):
    global PROBLEM
    PROBLEM = load_problem(path)


def evaluate(x) -> tuple[list[float], float]:
    """(F, CV) of one NSGA-II individual by the exact evaluator."""
    p = PROBLEM
    free = p.free_lengths()
    counts = p.counts()
    values = p.start_values() | dict(zip(free, map(float, x[:len(free)])))
    values[p.model.count_variable] = counts[min(int(x[-1]), len(counts) - 1)]
    try:
        ver = verify(p, values)
    except (OptDesignError, ValueError, ArithmeticError):
        return [2.0, 0.0], 1e3
    if ver.delta is None:
        return [2.0, 0.0], 1e3
    cv = sum(min(v, 1e3) for v in ver.violations.values())
    return [ver.delta, -ver.ratio], cv


def run_nsga(path, budget_s: float, workers: int, pop: int = 60, seed: int = 1):
    from pymoo.algorithms.moo.nsga2 import NSGA2
    from pymoo.core.callback import Callback
    from pymoo.core.problem import Problem
    from pymoo.optimize import minimize
    from pymoo.termination import get_termination

    p = load_problem(path)
    free = p.free_lengths()
    xl = [p.design[k].lower for k in free] + [0.0]
    xu = [p.design[k].upper for k in free] + [len(p.counts()) - 1e-9]
    pool = mp.get_context("fork").Pool(workers, initializer=_init, initargs=(str(path),))

    class Front(Problem):
        def __init__(self):
            super().__init__(n_var=len(xl), n_obj=2, n_ieq_constr=1, xl=np.array(xl),
                             xu=np.array(xu))

        def _evaluate(self, X, out, *args, **kwargs):
            res = pool.map(evaluate, list(X))
            out["F"] = np.array([r[0] for r in res])
            out["G"] = np.array([[r[1]] for r in res])

    history = []
    t0 = time.perf_counter()

    class Record(Callback):
        def notify(self, algorithm):
            opt = algorithm.opt
            feas = opt.get("CV")[:, 0] <= 0
            history.append((time.perf_counter() - t0, algorithm.evaluator.n_eval,
                            opt.get("F")[feas].tolist(), opt.get("X")[feas].tolist()))

    try:
        minimize(Front(), NSGA2(pop_size=pop), get_termination("time", budget_s),
                 seed=seed, callback=Record(), verbose=False)
    finally:
        pool.terminate()
    return history


def hv(f, ideal, nadir) -> float:
    f = np.asarray(f, float).reshape(-1, 2)
    if len(f) == 0:
        return 0.0
    z, _, _ = normalise(f, ideal, nadir)
    return hypervolume_2d(z)


def _journal_records(folder):
    from optdesign.pareto.store import Journal
    return Journal(Path(folder) / "points.jsonl").read()[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("problem", nargs="?", default="problems/pareto_fourbar.yaml")
    ap.add_argument("--out", default="results/bench_pareto")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--factor", type=float, default=10.0)
    ap.add_argument("--ours", help="reuse a finished sweep in this folder (its pareto.json)")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    problem = load_problem(args.problem)

    if args.ours:
        ours_json = json.loads((Path(args.ours) / "pareto.json").read_text())
    else:
        from optdesign.pareto import sweep
        sweep(problem, out / "ours", workers=args.workers)
        ours_json = json.loads((out / "ours" / "pareto.json").read_text())
    wall = ours_json["run"]["wall_time_s"]
    pts = [r for r in ours_json["points"] if r["status"] == "optimal"]
    finished = {tuple(r["key"]): r.get("finished_s") for r in _journal_records(args.ours or
                                                                         out / "ours")}
    for r in pts:
        r["finished_s"] = finished.get((r["phases"], r["index"])) or wall
    f_ours = objectives([r["delta"] for r in pts], [r["ratio"] for r in pts])

    print(f"sweep: {len(pts)} verified points in {wall:.1f} s; NSGA-II gets "
          f"{args.factor * wall:.0f} s on {args.workers} processes", flush=True)
    history = run_nsga(args.problem, args.factor * wall, args.workers)
    f_nsga = np.array(history[-1][2]).reshape(-1, 2) if history else np.zeros((0, 2))

    union = np.vstack([f_ours, f_nsga])
    union = union[non_dominated(union)]
    ideal, nadir = union.min(axis=0), union.max(axis=0)

    order = np.argsort([r["finished_s"] for r in pts])
    ours_curve = [(pts[i]["finished_s"], hv(f_ours[order[:k + 1]], ideal, nadir))
                  for k, i in enumerate(order)]
    nsga_curve = [(t, hv(F, ideal, nadir)) for t, _, F, _ in history]
    hv_ours = ours_curve[-1][1]

    def nsga_at(t):
        before = [h for s, h in nsga_curve if s <= t]
        return before[-1] if before else 0.0

    rows = [("ε-constraint sweep (optdesign pareto)", f"{wall:.0f}", f"{hv_ours:.4f}",
             str(int(non_dominated(f_ours).sum())))]
    for mult in (1, 2, 5, args.factor):
        t = mult * wall
        idx = [k for k, h in enumerate(history) if h[0] <= t]
        n_front = len(history[idx[-1]][2]) if idx else 0
        evals = history[idx[-1]][1] if idx else 0
        rows.append((f"NSGA-II, {mult:g}× our time ({evals} evaluations)", f"{t:.0f}",
                     f"{nsga_at(t):.4f}", str(n_front)))
    table = ["| method | wall time [s] | hypervolume | non-dominated points |",
             "|---|---:|---:|---:|"] + [f"| {' | '.join(r)} |" for r in rows]
    norm = (f"normalisation: ideal δ = {ideal[0]:.4f}, ratio = {-ideal[1]:.4f}; nadir "
            f"δ = {nadir[0]:.4f}, ratio = {-nadir[1]:.4f} (non-dominated union of both final "
            f"fronts); reference point (1.1, 1.1); largest possible 1.21")
    text = "\n".join(table) + "\n\n" + norm + "\n"
    print(text)
    (out / "bench.md").write_text(text)
    (out / "bench.json").write_text(json.dumps({
        "ours": {"wall_time_s": wall, "hypervolume": hv_ours, "curve": ours_curve},
        "nsga2": {"curve": nsga_curve, "front": f_nsga.tolist(),
                  "evaluations": history[-1][1] if history else 0},
        "ideal": ideal.tolist(), "nadir": nadir.tolist()}, indent=1))
    _figures(out, ours_curve, nsga_curve, f_ours, f_nsga, wall, args.factor)
    return 0




def _figures(out, ours_curve, nsga_curve, f_ours, f_nsga, wall, factor):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(12, 4.5))
    t, h = zip(*ours_curve)
    a.step(t, h, where="post", lw=2, label="ε-constraint sweep (IPOPT)")
    if nsga_curve:
        t, h = zip(*nsga_curve)
        a.step(t, h, where="post", lw=1.5, label="NSGA-II (pymoo)")
    a.axvline(wall, color="grey", ls=":", lw=1)
    a.axvline(factor * wall, color="grey", ls="--", lw=1)
    a.set_xscale("log")
    a.set_xlabel("wall time [s]")
    a.set_ylabel("hypervolume (normalised, ref. (1.1, 1.1))")
    a.set_title("hypervolume against time")
    a.legend()
    a.grid(alpha=0.3)
    nd = non_dominated(f_ours)
    b.plot(-f_ours[nd, 1], f_ours[nd, 0], "o", label="sweep (non-dominated)")
    if len(f_nsga):
        b.plot(-f_nsga[:, 1], f_nsga[:, 0], "x", label="NSGA-II final front")
    b.set_xlabel("ratio (mean output speed / ω1)")
    b.set_ylabel("ripple δ")
    b.set_title("fronts")
    b.legend()
    b.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "hv_vs_time.png", dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())

"""`optdesign pareto` against the multi-objective optimisers a designer would write himself.

The race. For every problem, ours first: ``optdesign pareto P.yaml --out DIR --workers 2`` in
a child process of its own (``OPTDESIGN_SERVER=off``: a session's first command, not one the
warm server forks), timed around the whole process as a user waits for it (start-up, imports,
the sweep, the report and figures): T_ours. Before the race every NLP the sweeps build is
compiled into the user's cache (``--no-warm-up`` skips that: a problem's first run then runs
on CasADi's virtual machine with a compiler beside it). Our front is the verified points (``optimal`` or ``local``) of
DIR/pareto.json, each re-verified here. Then two peers, each for a wall-time budget of
min(--budget-factor · T_ours, --cap) seconds, on one core:

* **The designer's model**: ``solve_vs_peers.DesignerModel`` (imported, not copied): NumPy,
  vectorised over (population × 360 crank samples), both converters' speeds in closed form,
  the envelope's extremes refined between samples; its speeds agree with our CasADi model to
  ~1e-15 (``validate``, run for every problem and reported). Objectives (δ, −ratio), δ the
  worst over the listed eccentricities and the ratio at e = 1, as ours.
* **Constraints** through pymoo's own handling (G ≤ 0, feasibility first: a feasible design
  beats an infeasible one, two infeasible ones compare by their summed violation): the
  transmission angle (every chain, sample and eccentricity), the pin radius and l1 < l0 of the
  four-bar, the slotted lever's assembly margin, the ratio floor where the file sets one;
  a design that does not assemble gets G = 1e3. The same G as the single-objective race.
* **The phase count** is one more variable (its index among the admissible counts, a
  continuous gene rounded by the model, as the single-objective race's GA does): one run per
  count would split the budget evenly, including the counts whose front is dominated, where
  one run lets the evolution spend it where the overall front is.
* **Peers**, pymoo 0.6 with its defaults, population 100, seed --seed, stopped by
  ``TimeBasedTermination`` at the budget:
  (a) NSGA-II (SBX η = 15, polynomial mutation η = 20, binary tournament on rank and crowding);
  (b) SMS-EMOA (the same operators, survival by least hypervolume contribution, computed by
  moocore). SMS-EMOA suits two objectives well: the contributions are exact and cheap there.
  Both evaluate a whole population per call, so the vectorised model costs milliseconds a
  generation; a second process would not help them.
* **The archive.** Every evaluated design that is feasible on the designer's model goes into
  a non-dominated archive, one per phase count (the evaluation wrapper sees every design, not
  only the survivors: more generous to the peers than pymoo's ``res.opt``); a pymoo callback
  takes a snapshot of it at ~48 log-spaced times. What a peer "has" at time t is the
  non-dominated union of its archives then, thinned to as many designs as our non-dominated
  front has (at least --archive-max: hypervolume grows with the number of points, so a peer
  is never held to fewer than we show) by dropping the least hypervolume contributor one at
  a time (exact verification costs ~10-30 ms a design).

Scoring. Every point of every method is re-verified EXACTLY (``optdesign.solver.verify``, the
evaluator and tolerances of ``optdesign pareto``); a peer's point that fails there is dropped
and counted. One normalisation per problem: ideal and nadir of the non-dominated union of every
method's verified final front, reference point (1.1, 1.1) in normalised (δ, −ratio), so the
largest hypervolume is 1.21; hypervolumes by ``moocore.hypervolume``. A peer's hypervolume over
time is that of its verified thinned archive at 8 log-spaced checkpoints (budget/100 to the
budget) and at T_ours; the time to reach our hypervolume is refined between checkpoints by
bisection over the snapshots. Ours over time: each point counts from the moment the sweep
journalled it (``finished_s`` in points.jsonl), shifted by the process's start-up and report
time (which makes our curve late, never early); on the same clock, the times at which our
uniform pass, our per-count refinement and our hypervolume rounds were in (second table).
The domination margin: the largest δ_o − δ_p
over our non-dominated points o and the peer's verified points p with ratio_p ≥ ratio_o (any
phase count), and over our points of each count's own front against the peer's of the same
count (same count); positive means a peer design beats ours by that much in δ at no lower
ratio (``pareto_scoring.domination_margin``).

Problems (``CASES``, each swept by ``optdesign pareto`` in 10-30 s with --workers 2):
pareto_fourbar.yaml (four-bar, every length free, reverse stroke, n ∈ {4, 6}),
pareto_disc_three_counts.yaml (four-bar, the paper's disc and crank kept, reverse stroke,
n ∈ {4, 6, 8}), pareto_slotted_forward.yaml (slotted lever, forward stroke, n ∈ {3, 4, 5}),
pareto_reverse_flat.yaml (four-bar, reverse stroke, n ∈ {4, 6, 8}: n = 4 and 6 one design
each, n = 8 a front whose δ moves by 0.6 % over its ratio range, a flat count).
The four-bar's forward stroke has no front (docs/pareto.md), hence the slotted lever there.

    python benchmarks/pareto_vs_peers.py [--quick] [--problems NAME ...] [--peers nsga2 smsemoa]
        [--budget-factor 10] [--cap 300] [--seed 1] [--workers 2] [--archive-max 100]

About 25 minutes with the defaults on 2 cores (each peer's budget is 10·T_ours, at most 300 s).
Writes benchmarks/results/pareto_vs_peers.{md,json} and docs/figures/pareto_vs_peers.png
(``--quick``, a one-minute smoke run: pareto_fourbar alone, budgets ≤ 6 s, to *_quick files in
benchmarks/results, nothing under docs/).
"""
from __future__ import annotations

import argparse
import json
import math
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from pareto_scoring import (Normalisation, beaten_optima, checkpoint_times,  # noqa: E402
                            domination_margin, format_margin, non_dominated, objectives, thin,
                            value_at)
from solve_vs_peers import DesignerModel, validate  # noqa: E402
from warm_cache import warm_up  # noqa: E402

from optdesign.errors import OptDesignError  # noqa: E402
from optdesign.outputs.atomic import atomic_write_text  # noqa: E402
from optdesign.commands.files import save_figure  # noqa: E402
from optdesign.fronts.refine import MAX_ROUNDS  # noqa: E402
from optdesign.problem.loader import load_problem  # noqa: E402

CASES = {"pareto_fourbar": "pareto_fourbar.yaml",
         "pareto_disc_three_counts": "pareto_disc_three_counts.yaml",
         "pareto_slotted_forward": "pareto_slotted_forward.yaml",
         "pareto_reverse_flat": "pareto_reverse_flat.yaml"}
QUICK_CASES = ("pareto_fourbar",)
PEERS = ("NSGA-II (pymoo)", "SMS-EMOA (pymoo)")
PEER_KEYS = {"nsga2": PEERS[0], "smsemoa": PEERS[1]}
POP_SIZE = 100
SNAPSHOTS = 48
#: objectives given to pymoo for a design whose δ is not finite (it also gets G = 1e3)
UNUSABLE_F = (10.0, 0.0)


# --------------------------------------------------------------------------- exact verification
_PROBLEM = None        # the problem of the verifying processes (set before they fork)


def _verify_one(values: dict) -> dict:
    from optdesign.solver import verify

    try:
        v = verify(_PROBLEM, values)
        return {"feasible": bool(v.feasible) and v.delta is not None, "delta": v.delta,
                "ratio": v.ratio}
    except (OptDesignError, ValueError, ArithmeticError) as exc:
        return {"feasible": False, "delta": None, "ratio": None, "error": str(exc)}


class Verifier:
    """Exact figures of designs (``optdesign.solver.verify``), each design verified once, on
    ``workers`` processes (the cores are idle then: ours and the peers have finished)."""

    def __init__(self, problem, model: DesignerModel, workers: int = 2):
        global _PROBLEM
        _PROBLEM = problem
        self.problem, self.model, self.workers = problem, model, workers
        self.cache: dict[tuple, dict] = {}
        self.pool = None

    def close(self) -> None:
        if self.pool is not None:
            self.pool.shutdown()
            self.pool = None

    def many(self, designs: list[dict]) -> list[dict]:
        """Verified figures of each design dict (the problem's keys, count included)."""
        keys = [tuple(sorted((k, round(float(v), 12)) for k, v in d.items())) for d in designs]
        todo = {k: d for k, d in zip(keys, designs) if k not in self.cache}
        if len(todo) > 4 and self.workers > 1:
            if self.pool is None:
                import multiprocessing
                from concurrent.futures import ProcessPoolExecutor
                self.pool = ProcessPoolExecutor(self.workers,
                                                mp_context=multiprocessing.get_context("fork"))
            done = list(self.pool.map(_verify_one, todo.values(), chunksize=4))
        else:
            done = [_verify_one(d) for d in todo.values()]
        count = self.model.count_key
        for (k, d), out in zip(todo.items(), done):
            self.cache[k] = out | {"phases": int(d[count])}
        return [self.cache[k] for k in keys]

    def designs(self, X: np.ndarray, idx: np.ndarray) -> tuple[list[dict], int]:
        """(verified feasible points, how many failed) of the model's designs (x, count index)."""
        out = self.many([self.model.values(x, int(i)) for x, i in zip(X, idx)])
        points = [p for p in out if p["feasible"]]
        return points, len(out) - len(points)


def f_of(points: list[dict]) -> np.ndarray:
    return objectives([p["delta"] for p in points], [p["ratio"] for p in points])


def front_of(points: list[dict]) -> list[dict]:
    """The non-dominated points across every count."""
    mask = non_dominated(f_of(points))
    return [p for p, keep in zip(points, mask) if keep]


def count_fronts_of(points: list[dict]) -> list[dict]:
    """The points non-dominated within their own phase count."""
    out = []
    for n in sorted({p["phases"] for p in points}):
        out += front_of([p for p in points if p["phases"] == n])
    return out


# --------------------------------------------------------------------------- ours
def optdesign_command() -> list[str]:
    """The `optdesign` command of this interpreter's environment."""
    script = Path(sys.executable).parent / "optdesign"
    return [str(script)] if script.is_file() else [sys.executable, "-m", "optdesign"]


def compile_first(cases, workers: int, log) -> None:
    """Every NLP each problem's sweep builds compiled into the user's cache first
    (``benchmarks/warm_cache.py``): T_ours is a run on compiled derivatives, as every run
    after a problem's first (which runs on CasADi's virtual machine with the build beside
    it, a compiler taking a core)."""
    with tempfile.TemporaryDirectory(prefix="pareto_race_warm_") as tmp:
        for case in cases:
            warm_up(case, optdesign_command() + ["pareto", f"problems/{CASES[case]}",
                                                 "--workers", str(workers), "--no-report"],
                    Path(tmp), log)


def children_cpu_s() -> float:
    """CPU seconds of this process's finished children (ours and its worker processes)."""
    import resource

    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def run_ours(path: Path, workers: int, verifier: Verifier, log) -> dict:
    """`optdesign pareto` in a child process, timed around it; our points re-verified."""
    problem = verifier.problem
    with tempfile.TemporaryDirectory(prefix="pareto_race_") as tmp:
        out = Path(tmp) / "front"
        args = ["pareto", str(path.relative_to(ROOT)), "--out", str(out), "--workers",
                str(workers)]
        cpu0, t0 = children_cpu_s(), time.perf_counter()
        # a process of its own, as a session's first command: a warm server (docs/
        # warm-server.md) would fork it from its memory, out of reach of RUSAGE_CHILDREN
        proc = subprocess.run(optdesign_command() + args, capture_output=True, text=True,
                              cwd=ROOT, env=os.environ | {"OPTDESIGN_SERVER": "off"})
        wall, cpu = time.perf_counter() - t0, children_cpu_s() - cpu0
        if proc.returncode != 0:
            raise RuntimeError(f"optdesign {' '.join(args)} exited {proc.returncode}:\n"
                               f"{proc.stderr[-3000:]}")
        data = json.loads((out / "pareto.json").read_text(encoding="utf-8"))
        finished, rounds = {}, []
        for line in (out / "points.jsonl").read_text(encoding="utf-8").splitlines()[1:]:
            rec = json.loads(line)
            if isinstance(rec.get("key"), list) and "finished_s" in rec:
                finished[tuple(rec["key"])] = rec["finished_s"]
                rounds.append((rec.get("round") or 0, rec["finished_s"]))
    sweep_s = float(data["run"].get("wall_time_s", wall))
    overhead = max(wall - sweep_s, 0.0)         # start-up and report: counted before the points
    # when the uniform pass (round 0, both ends included), the per-count refinement (rounds
    # 1-MAX_ROUNDS) and everything had been journalled, counted as the curve is
    stages = {}
    for stage, last in (("uniform", 0), ("refined", MAX_ROUNDS)):
        done = [(f, r) for r, f in rounds if r <= last]
        if done:
            stages[stage] = {"t": min(wall, overhead + max(f for f, _ in done)),
                             "points": len(done)}
    stages["all"] = {"t": wall, "points": len(rounds)}
    rows = [r for r in data["points"] if r.get("status") in ("optimal", "local")]
    designs = []
    for row in rows:
        values = problem.start_values() | {k: row[k] for k in problem.model.lengths
                                           if row.get(k) is not None}
        designs.append(values | {problem.model.count_variable: row["phases"]})
    points, dropped, claims = [], 0, []
    for row, p in zip(rows, verifier.many(designs)):
        if not p["feasible"]:
            dropped += 1
            continue
        done = finished.get((row["phases"], row.get("index")))
        points.append(dict(p, t=min(wall, overhead + done) if done is not None else wall))
        claims.append({"status": row["status"], "kind": row.get("kind"),
                       "epsilon": row.get("epsilon"), "phases": row["phases"],
                       "delta": p["delta"], "ratio": p["ratio"]})
    log(f"  ours: {len(points)} verified points ({dropped} failed re-verification) in "
        f"{wall:.2f} s (sweep {sweep_s:.2f} s, CPU {cpu:.1f} s)")
    return {"time_s": wall, "sweep_time_s": sweep_s, "cpu_s": cpu, "points": points,
            "stages": stages, "inconsistent": beaten_optima(claims),
            "dropped": dropped, "command": "optdesign " + " ".join(args[:3] + ["DIR"] + args[4:])}


# --------------------------------------------------------------------------- peers
class Archive:
    """One peer's record: evaluates populations on the designer's model, keeps per phase-count
    index the non-dominated designs feasible on it, and snapshots them at given times."""

    def __init__(self, model: DesignerModel, budget: float, times):
        self.model, self.budget = model, budget
        self.pending = sorted(times)
        self.fronts: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self.snapshots: list[tuple[float, dict]] = []
        self.nfev = 0
        self.t0 = time.perf_counter()

    def start(self) -> None:
        self.t0 = time.perf_counter()

    def elapsed(self) -> float:
        return time.perf_counter() - self.t0

    def tick(self) -> None:
        """Snapshot the archive for every snapshot time that has passed."""
        t = self.elapsed()
        while self.pending and self.pending[0] <= t:
            self.snapshots.append((self.pending.pop(0), dict(self.fronts)))

    def finish(self) -> None:
        """The remaining snapshot times, and the budget's end, get the final archive."""
        while self.pending:
            self.snapshots.append((self.pending.pop(0), dict(self.fronts)))
        self.snapshots.append((self.budget, dict(self.fronts)))

    def __call__(self, x: np.ndarray, idx: np.ndarray) -> dict:
        out = self.model.evaluate(x, idx)
        self.nfev += len(x)
        F = objectives(out["delta"], out["ratio"])
        ok = out["ok"] & np.all(out["G"] <= 0, axis=1) & np.all(np.isfinite(F), axis=1)
        for i in np.unique(idx[ok]):
            rows = ok & (idx == i)
            X_old, F_old = self.fronts.get(int(i), (np.zeros((0, x.shape[1])), np.zeros((0, 2))))
            X_all, F_all = np.vstack([X_old, x[rows]]), np.vstack([F_old, F[rows]])
            keep = non_dominated(F_all)
            self.fronts[int(i)] = (X_all[keep], F_all[keep])
        return out

    @staticmethod
    def union(fronts: dict, k: int) -> tuple[np.ndarray, np.ndarray]:
        """(X, idx) of the thinned non-dominated union of per-count fronts."""
        if not fronts:
            return np.zeros((0, 0)), np.zeros(0, int)
        X = np.vstack([fronts[i][0] for i in sorted(fronts)])
        F = np.vstack([fronts[i][1] for i in sorted(fronts)])
        idx = np.concatenate([np.full(len(fronts[i][1]), i) for i in sorted(fronts)])
        keep = thin(F, k)
        return X[keep], idx[keep]


def run_peer(name: str, archive: Archive, seed: int) -> None:
    """One pymoo run on the designer's model until the archive's budget."""
    from pymoo.algorithms.moo.nsga2 import NSGA2
    from pymoo.algorithms.moo.sms import SMSEMOA
    from pymoo.core.callback import Callback
    from pymoo.core.problem import Problem
    from pymoo.optimize import minimize
    from pymoo.termination.max_time import TimeBasedTermination

    m = archive.model
    K = len(m.counts)
    xl = np.concatenate([m.lower, [-0.49] if K > 1 else []])
    xu = np.concatenate([m.upper, [K - 0.51] if K > 1 else []])
    n_constr = m.evaluate(((m.lower + m.upper) / 2)[None, :])["G"].shape[1]
    m.nfev = 0

    class Front(Problem):
        def __init__(self):
            super().__init__(n_var=xl.size, n_obj=2, n_ieq_constr=n_constr, xl=xl, xu=xu)

        def _evaluate(self, X, out, *args, **kwargs):
            idx = (np.rint(np.clip(X[:, m.dim], 0, K - 1)).astype(int) if K > 1
                   else np.zeros(len(X), int))
            o = archive(X[:, :m.dim], idx)
            F = objectives(o["delta"], o["ratio"])
            F[~np.all(np.isfinite(F), axis=1)] = UNUSABLE_F
            out["F"], out["G"] = F, o["G"]

    class Snapshots(Callback):
        def notify(self, algorithm):
            archive.tick()

    algorithm = (NSGA2 if name == PEERS[0] else SMSEMOA)(pop_size=POP_SIZE)
    archive.start()
    minimize(Front(), algorithm, TimeBasedTermination(archive.budget), seed=seed,
             callback=Snapshots(), verbose=False)
    archive.finish()


# --------------------------------------------------------------------------- scoring
def score_peer(archive: Archive, verifier: Verifier, k: int) -> dict:
    """The peer's verified final answer: its thinned overall front and, for the same-count
    margin, each count's own front (thinned too)."""
    final = archive.snapshots[-1][1]
    X, idx = Archive.union(final, k)
    front, dropped = verifier.designs(X, idx)
    by_count, dropped_count = [], 0
    for i in sorted(final):
        Xi, Fi = final[i]
        keep = thin(Fi, k)
        pts, d = verifier.designs(Xi[keep], np.full(len(keep), i))
        by_count += pts
        dropped_count += d
    return {"front": front, "dropped": dropped, "count_points": by_count,
            "count_dropped": dropped_count,
            "sampled_points": int(sum(len(f[1]) for f in final.values()))}


def peer_curve(archive: Archive, verifier: Verifier, norm: Normalisation, checkpoints, k: int):
    """[(t, hypervolume, verified points, dropped)] at the checkpoints (the snapshot at or
    before each)."""
    curve = []
    for t in checkpoints:
        snap = [s for s in archive.snapshots if s[0] <= t + 1e-9]
        if not snap:
            curve.append((t, 0.0, 0, 0))
            continue
        pts, dropped = verifier.designs(*Archive.union(snap[-1][1], k))
        curve.append((t, norm.hypervolume(f_of(pts)) if pts else 0.0, len(pts), dropped))
    return curve


def time_to_reach(archive: Archive, verifier: Verifier, norm: Normalisation, curve, target: float,
                  k: int):
    """First time the peer's verified hypervolume reaches ``target``: the first checkpoint that
    does, refined by bisection over the snapshots since the checkpoint before it."""
    hit = next((j for j, c in enumerate(curve) if c[1] >= target), None)
    if hit is None:
        return None
    lo_t = curve[hit - 1][0] if hit > 0 else -math.inf
    between = [s for s in archive.snapshots if lo_t < s[0] <= curve[hit][0]]
    lo, hi = -1, len(between) - 1                # between[hi] reaches the target (or is the hit)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        pts, _ = verifier.designs(*Archive.union(between[mid][1], k))
        if pts and norm.hypervolume(f_of(pts)) >= target:
            hi = mid
        else:
            lo = mid
    return between[hi][0] if between else curve[hit][0]


def ours_curve(points: list[dict], norm: Normalisation) -> list[tuple[float, float]]:
    """Our hypervolume as the points were journalled."""
    order = sorted(points, key=lambda p: p["t"])
    return [(p["t"], norm.hypervolume(f_of(order[:j + 1]))) for j, p in enumerate(order)]


def plain(points: list[dict]) -> list[dict]:
    return [{k: p[k] for k in ("phases", "delta", "ratio")} for p in points]


# --------------------------------------------------------------------------- one problem
def race(case: str, args, log) -> dict:
    path = ROOT / "problems" / CASES[case]
    problem = load_problem(path)
    model = DesignerModel(problem, args.samples, refine=True)
    verifier = Verifier(problem, model, args.workers)
    log(f"[{case}]")
    try:
        return _race(case, path, problem, model, verifier, args, log)
    finally:
        verifier.close()


def _race(case, path, problem, model, verifier, args, log) -> dict:
    ours = run_ours(path, args.workers, verifier, log)
    t_ours = ours["time_s"]
    budget = min(args.budget_factor * t_ours, args.cap)
    checkpoints = checkpoint_times(t_ours, budget, 8)
    snapshots = sorted(set(np.geomspace(budget / 1000, budget, SNAPSHOTS).tolist())
                       | set(checkpoints))
    residual = validate(problem, trials=8)
    import pymoo.algorithms.moo.nsga2  # noqa: F401  (imports outside the peers' clocks)
    import pymoo.algorithms.moo.sms  # noqa: F401
    import pymoo.optimize  # noqa: F401
    archives = {}
    for name in args.peers:
        archives[name] = Archive(model, budget, snapshots)
        run_peer(name, archives[name], args.seed)
        log(f"  {name}: {archives[name].nfev} designs in {archives[name].elapsed():.1f} s")
    our_front = front_of(ours["points"])
    # a peer keeps as many designs as our front shows, at least --archive-max: hypervolume
    # grows with the number of points, and a peer's archive holds thousands
    keep = max(args.archive_max, len(our_front))
    finals = {name: score_peer(a, verifier, keep) for name, a in archives.items()}
    norm = Normalisation.of_fronts([f_of(our_front)] + [f_of(front_of(f["front"] +
                                                                      f["count_points"]))
                                                        for f in finals.values()])
    hv_ours = norm.hypervolume(f_of(our_front))
    count_fronts = count_fronts_of(ours["points"])
    peers = {}
    for name, a in archives.items():
        curve = peer_curve(a, verifier, norm, checkpoints, keep)
        everything = finals[name]["front"] + finals[name]["count_points"]
        hit = time_to_reach(a, verifier, norm, curve, hv_ours, keep)
        peers[name] = {
            "budget_s": budget, "elapsed_s": a.elapsed(), "designs_evaluated": a.nfev,
            "archive_max": keep,
            "hv_at_t_ours": value_at([(t, h) for t, h, *_ in curve], t_ours),
            "hv_at_budget": curve[-1][1],
            "time_to_our_hv_s": hit,
            "front": plain(front_of(finals[name]["front"])),
            "points": plain(finals[name]["front"]),
            "count_points": plain(finals[name]["count_points"]),
            "points_verified": len(finals[name]["front"]),
            "points_dropped": finals[name]["dropped"],
            "count_points_verified": len(finals[name]["count_points"]),
            "count_points_dropped": finals[name]["count_dropped"],
            "archive_size": finals[name]["sampled_points"],
            "margin_any_count": domination_margin(our_front, everything),
            "margin_same_count": domination_margin(count_fronts, finals[name]["count_points"],
                                                   same_count=True),
            "curve": [{"t": t, "hypervolume": h, "verified": n, "dropped": d}
                      for t, h, n, d in curve]}
        p = peers[name]
        log(f"  {name}: HV {p['hv_at_t_ours']:.4f} at T_ours, {p['hv_at_budget']:.4f} at "
            f"{budget:.0f} s (ours {hv_ours:.4f}); reaches ours "
            f"{'at %.2f s' % hit if hit is not None else 'never'}")
    return {"case": case, "file": f"problems/{CASES[case]}", "validation_residual": residual,
            "normalisation": norm.to_dict(), "budget_s": budget, "checkpoints_s": checkpoints,
            "ours": {"time_s": t_ours, "sweep_time_s": ours["sweep_time_s"],
                     "inconsistent_optima": ours["inconsistent"],
                     "cpu_s": ours["cpu_s"], "command": ours["command"], "hypervolume": hv_ours,
                     "stages": ours["stages"],
                     "points_verified": len(ours["points"]), "points_dropped": ours["dropped"],
                     "front": plain(our_front), "count_fronts": plain(count_fronts),
                     "curve": [{"t": t, "hypervolume": h}
                               for t, h in ours_curve(ours["points"], norm)]},
            "peers": peers}


# --------------------------------------------------------------------------- output
def table(results: list[dict], factor: float) -> str:
    lines = [f"| problem | method | wall time [s] | verified points (dropped) | hypervolume at "
             f"T_ours | at {factor:g}·T_ours | time to our hypervolume [s] | × T_ours | designs "
             f"evaluated | δ margin, any count | δ margin, same count |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        o, t = r["ours"], r["ours"]["time_s"]
        lines.append(f"| {r['case']} | optdesign pareto | {t:.1f} | {o['points_verified']} "
                     f"({o['points_dropped']}) | {o['hypervolume']:.4f} | {o['hypervolume']:.4f}"
                     f" | {t:.1f} | 1.0 | – | – | – |")
        for name, p in r["peers"].items():
            capped = "" if p["budget_s"] >= factor * t - 1e-9 else f" (cap {p['budget_s']:.0f} s)"
            hit = p["time_to_our_hv_s"]
            lines.append(
                f"| {r['case']} | {name} | {p['budget_s']:.1f} | {p['points_verified']} "
                f"({p['points_dropped']}) | {p['hv_at_t_ours']:.4f} | {p['hv_at_budget']:.4f}"
                f"{capped} | {'never' if hit is None else f'{hit:.1f}'} | "
                f"{'–' if hit is None else f'{hit / t:.1f}'} | {p['designs_evaluated']} | "
                f"{format_margin(p['margin_any_count'])} | "
                f"{format_margin(p['margin_same_count'])} |")
    return "\n".join(lines)


def stages(done: dict) -> str:
    """When our uniform pass, per-count refinement and hypervolume rounds were in."""
    return " / ".join(f"{done[k]['t']:.1f} ({done[k]['points']})" if k in done else "–"
                      for k in ("uniform", "refined", "all"))


def normalisation_table(results: list[dict]) -> str:
    lines = ["| problem | file | ideal δ | ideal ratio | nadir δ | nadir ratio | our sweep alone "
             "[s] | our CPU [s] | ours: uniform pass / refined / all [s] (journalled points) | "
             "max \\|NumPy − CasADi\\| |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        n = r["normalisation"]
        lines.append(f"| {r['case']} | `{r['file']}` | {n['ideal']['delta']:.4f} | "
                     f"{n['ideal']['ratio']:.4f} | {n['nadir']['delta']:.4f} | "
                     f"{n['nadir']['ratio']:.4f} | {r['ours']['sweep_time_s']:.1f} | "
                     f"{r['ours']['cpu_s']:.1f} | {stages(r['ours'].get('stages', {}))} | "
                     f"{r['validation_residual']:.0e} |")
    return "\n".join(lines)


def verdicts(results: list[dict]) -> str:
    """One line per problem and peer saying plainly where ours loses."""
    lines = []
    for r in results:
        hv, t = r["ours"]["hypervolume"], r["ours"]["time_s"]
        for name, p in r["peers"].items():
            said = []
            if p["time_to_our_hv_s"] is not None:
                said.append(f"reaches our hypervolume at {p['time_to_our_hv_s']:.1f} s "
                            f"({p['time_to_our_hv_s'] / t:.1f}× our time)")
            m = p["margin_any_count"]
            if m is not None and m["margin"] > 0:
                said.append(f"dominates one of our points by {m['margin']:.2e} in δ "
                            f"(ours n = {m['ours']['phases']}, δ {m['ours']['delta']:.4f} at "
                            f"ratio {m['ours']['ratio']:.4f}; its δ {m['peer']['delta']:.4f} at "
                            f"ratio {m['peer']['ratio']:.4f})")
            bad = r["ours"].get("inconsistent_optima", 0)
            if bad:
                said.append(f"{bad} of our points called optimal are beaten on their own ε "
                            f"by another of our verified designs")
            verdict = "ours LOSES: " + "; ".join(said) if said else \
                f"ours wins: {p['hv_at_budget']:.4f} against our {hv:.4f}, no point of ours " \
                f"dominated, no optimum of ours beaten on its own ε"
            lines.append(f"- {r['case']}, {name}: {verdict}.")
    return "\n".join(lines)


def figure(results: list[dict], path: Path) -> None:
    """Per problem: hypervolume against wall time (log), our point starred; the fronts."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    colours = {PEERS[0]: "tab:blue", PEERS[1]: "tab:orange"}
    k = len(results)
    fig, axes = plt.subplots(2, k, figsize=(5.4 * k, 8.4), squeeze=False)
    for j, r in enumerate(results):
        ax, fr = axes[0, j], axes[1, j]
        o, t = r["ours"], r["ours"]["time_s"]
        for name, p in r["peers"].items():
            ts = [c["t"] for c in p["curve"]]
            ax.step(ts, [c["hypervolume"] for c in p["curve"]], where="post", marker="o",
                    ms=3, color=colours.get(name), label=name)
            f = p["front"]
            fr.plot([q["ratio"] for q in f], [q["delta"] for q in f], "x", ms=4,
                    color=colours.get(name), label=f"{name}, final")
        if o["curve"]:
            ax.step([c["t"] for c in o["curve"]] + [max(r["budget_s"], t)],
                    [c["hypervolume"] for c in o["curve"]] + [o["hypervolume"]], where="post",
                    color="k", lw=1.2, label="optdesign pareto (as journalled)")
        ax.plot([t], [o["hypervolume"]], "k*", ms=13, zorder=5)
        for mult, style in ((1, ":"), (r["budget_s"] / t, "--")):
            ax.axvline(mult * t, color="grey", lw=0.8, ls=style)
        ax.set_xscale("log")
        ax.set_xlabel("wall time [s]")
        ax.set_ylabel("hypervolume (one normalisation, ref. (1.1, 1.1))")
        ax.set_title(f"{r['case']}: T_ours = {t:.1f} s, peers {r['budget_s']:.0f} s")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7, loc="lower right")
        f = o["front"]
        fr.plot([q["ratio"] for q in f], [q["delta"] for q in f], "ko", mfc="none", ms=6,
                label="optdesign pareto")
        fr.set_xlabel("ratio (exact)")
        fr.set_ylabel("δ (exact)")
        fr.grid(True, alpha=0.3)
        fr.legend(fontsize=7)
    fig.tight_layout()
    save_figure(fig, path, dpi=100, bbox_inches=None)


# --------------------------------------------------------------------------- main
def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--problems", nargs="+", choices=sorted(CASES), default=None)
    ap.add_argument("--peers", nargs="+", choices=sorted(PEER_KEYS), default=None,
                    help="nsga2, smsemoa (default: both)")
    ap.add_argument("--budget-factor", type=float, default=10.0, help="peer budget / T_ours")
    ap.add_argument("--cap", type=float, default=300.0, help="largest peer budget [s]")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--workers", type=int, default=2, help="workers of optdesign pareto")
    ap.add_argument("--samples", type=int, default=360, help="crank samples of the peers")
    ap.add_argument("--archive-max", type=int, default=POP_SIZE,
                    help="least number of designs of a peer's archive verified at a "
                         "checkpoint (more when our front has more)")
    ap.add_argument("--quick", action="store_true",
                    help=f"smoke run (~1 min): {', '.join(QUICK_CASES)}, budgets ≤ 6 s, "
                         f"results to *_quick files")
    ap.add_argument("--no-warm-up", action="store_true",
                    help="race with the cache as it is (a problem's first run builds its NLPs' "
                         "libraries beside it, on the virtual machine)")
    args = ap.parse_args(argv)
    args.peers = [PEER_KEYS[k] for k in args.peers] if args.peers else list(PEERS)
    cases = args.problems or (list(QUICK_CASES) if args.quick else list(CASES))
    if args.quick:
        args.cap = min(args.cap, 6.0)
    log = lambda s: print(s, file=sys.stderr, flush=True)  # noqa: E731
    t0 = time.perf_counter()
    if not args.no_warm_up:
        compile_first(cases, args.workers, log)
    results = [race(case, args, log) for case in cases]
    header = (f"Every point of every method verified exactly (`optdesign.solver.verify`); peers "
              f"on the designer's NumPy model ({args.samples} samples, refined), population "
              f"{POP_SIZE}, seed {args.seed}, budget min({args.budget_factor:g}·T_ours, "
              f"{args.cap:g} s); a peer's archive thinned at each checkpoint to as many designs "
              f"as our non-dominated front has, at least {args.archive_max} (hypervolume grows "
              f"with the number of points). Hypervolume by moocore on one normalisation per problem (ideal and "
              f"nadir of the non-dominated union of every method's verified final front, second "
              f"table), reference point (1.1, 1.1), at most 1.21. δ margin: the largest "
              f"δ_ours − δ_peer over pairs with ratio_peer ≥ ratio_ours; positive (bold) means "
              f"a peer design dominates one of ours by that much.\n\n")
    md = (header + table(results, args.budget_factor) + "\n\n" + normalisation_table(results) +
          "\n\n" + verdicts(results) + "\n")
    print(md)
    suffix = "_quick" if args.quick else ""
    out = ROOT / "benchmarks" / "results"
    atomic_write_text(out / f"pareto_vs_peers{suffix}.md", md)
    meta = {"args": vars(args), "python": sys.version.split()[0],
            "time": time.strftime("%Y-%m-%d %H:%M:%S"), "cores": os.cpu_count(),
            "machine": f"{platform.machine()} {platform.system()}",
            "total_s": time.perf_counter() - t0}
    atomic_write_text(out / f"pareto_vs_peers{suffix}.json",
                      json.dumps({"meta": meta, "results": results}, indent=1, default=float))
    fig_path = (out / "pareto_vs_peers_quick.png") if args.quick else \
        ROOT / "docs" / "figures" / "pareto_vs_peers.png"
    figure(results, fig_path)
    log(f"wrote {out / f'pareto_vs_peers{suffix}.md'}, .json and {fig_path} "
        f"({time.perf_counter() - t0:.0f} s in all)")
    return 0


if __name__ == "__main__":
    sys.exit(main())

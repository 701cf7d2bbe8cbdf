"""The ε-constraint sweep of ripple against ratio (docs/formulation.md, "The Pareto front").

For each admissible phase count: the two ends of the front (least ripple; largest ratio), then
K ε values evenly across the ratio range between them; at each, least δ subject to
ratio >= ε. The interior points are solved in *chains* that walk away from an end, each point
warm-started from its neighbour's design (the same NLP re-solved with a new ε parameter), with
the best basins of the solve's screening that reach ε as further starts (the screening run
once per count, :mod:`optdesign.fronts.seeds`), and the other end and then the multi-start
designs as fallbacks where a point fails. After the uniform pass, rounds of
:mod:`optdesign.fronts.refine` re-solve dominated points from the designs dominating them and
add ε values where the front is coarse. Chains of every count run in parallel on local
processes or on a Dask cluster; each finished point is appended to ``points.jsonl`` at once,
so an interrupted sweep resumes where it stopped.
"""
from __future__ import annotations

import hashlib
import os
import sys
import time
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor
from concurrent.futures import wait as _wait
from dataclasses import asdict
from pathlib import Path

import numpy as np

from optdesign.errors import OptDesignError, ProblemError
from optdesign.fronts import refine
from optdesign.fronts.axis import axis_of, with_axis
from optdesign.fronts.cluster import connect
from optdesign.fronts.files import write_front
from optdesign.fronts.front import ParetoResult, evaluate, frame
from optdesign.fronts.section import DEFAULT_POINTS, ParetoSection
from optdesign.fronts.store import Journal, to_solve_again
from optdesign.lifetime import die_with_parent, raise_if_terminated, signals_held
from optdesign.limits import local_processes
from optdesign.outputs.progress_lines import is_terminal
from optdesign.quantities.criteria import result_columns
from optdesign.solver import verify

#: pareto.csv/json are rebuilt from the journal at most this often while points come in, and
#: once at the end. A rebuild takes 50-120 ms of this process's time beside the workers, which
#: have every core (once a second: pareto_fourbar's sweep 4.09 s against 3.77 s without, medians
#: of three alternated runs on 2 cores). The journal is the record
#: (``--resume`` rebuilds from it); the files show a long sweep's front as it grows
REBUILD_EVERY_S = 5.0


def grid(section: ParetoSection, ends: dict, points: int) -> np.ndarray:
    """The ε values of one phase count: ``points`` evenly over the reachable range of the
    gain (the ratio, or another quantity: :mod:`optdesign.fronts.axis`), clipped to the
    section's ratio_lower/ratio_upper (empty when the span misses it)."""
    lo, hi = (refine.gain(e) for e in ends.values())
    if hi is None or hi < lo:
        hi = lo
    a = max(lo, section.ratio_lower) if section.ratio_lower is not None else lo
    b = min(hi, section.ratio_upper) if section.ratio_upper is not None else hi
    if b < a:
        return np.zeros(0)
    if b - a <= 1e-6 * max(1.0, b):
        return np.array([a])
    return np.linspace(a, b, points)



def _worker():
    """:mod:`optdesign.fronts.worker`, imported when the first point is submitted: it brings
    the solver and SciPy's statistics (most of a second), and every problem file with a
    ``pareto:`` section imports this package (its section's parser) whether it sweeps or not."""
    from optdesign.fronts import worker
    return worker

class _Inline:
    """Runs each task at submission, in this process (``workers=1``)."""

    def submit(self, fn, *args):
        fut = Future()
        try:
            fut.set_result(fn(*args))
        except BaseException as exc:        # surfaces in .result(), like a pool's future
            fut.set_exception(exc)
        return fut

    def wait_any(self, futures):
        return {f for f in futures if f.done()}

    def close(self, interrupted: bool = False):
        pass


class _Pool:
    """Local worker processes. Forked where the platform can (the parent holds no built NLP,
    and a forked worker needs no ``if __name__ == "__main__"`` guard in the caller's script).
    Each worker ends when this process dies, even by ``kill -9`` (:mod:`optdesign.lifetime`)."""

    def __init__(self, workers: int):
        import multiprocessing as mp
        method = "fork" if "fork" in mp.get_all_start_methods() else "spawn"
        self.pool = ProcessPoolExecutor(max_workers=workers, mp_context=mp.get_context(method),
                                        initializer=die_with_parent, initargs=(os.getpid(),))

    def submit(self, fn, *args):
        with signals_held():             # the first job forks the workers
            return self.pool.submit(fn, *args)

    def wait_any(self, futures):
        return _wait(futures, return_when=FIRST_COMPLETED).done

    def close(self, interrupted: bool = False):
        if interrupted:         # Ctrl-C or an error: do not wait for the points in flight
            for proc in list(getattr(self.pool, "_processes", {}).values()):
                proc.terminate()
        # waited for even when interrupted: the workers are ended, so the pool's manager
        # thread sees them gone at once; left running beside workers that died, it may use a
        # pipe the shutdown or the interpreter's exit closes under it ("OSError: [Errno 9]
        # Bad file descriptor" after the last line; CPython gh-132969, fixed after 3.11)
        self.pool.shutdown(wait=True, cancel_futures=True)


class _Dask:
    """The same tasks on a Dask distributed scheduler (``--scheduler ADDRESS``)."""

    def __init__(self, address):
        self.own = isinstance(address, str)
        self.client = connect(address)      # one deadline, a scheduler checked as such

    def submit(self, fn, *args):
        return self.client.submit(fn, *args, pure=False)

    def wait_any(self, futures):
        """The finished futures; a worker lost is Dask's affair (its tasks go to another),
        the scheduler lost ends the sweep with one line (the journal keeps the points)."""
        from distributed import wait
        from distributed.client import FutureCancelledError, FuturesCancelledError
        try:
            return wait(list(futures), return_when="FIRST_COMPLETED").done
        except (FutureCancelledError, FuturesCancelledError, OSError):
            raise OptDesignError(
                f"--scheduler {self.client.scheduler.address}: lost the scheduler; every "
                f"finished point is in the journal: restart the cluster and run again with "
                f"--resume") from None

    def close(self, interrupted: bool = False):
        if self.own:
            self.client.close()


def _executor(workers: int | None, scheduler):
    if scheduler is not None:
        return _Dask(scheduler)
    workers = local_processes(workers)
    return _Inline() if workers == 1 else _Pool(workers)


def _chains(indices: list[int], eps: np.ndarray, n_chains: int) -> list[list[int]]:
    """Contiguous blocks of the interior indices, each ordered away from its nearer end."""
    if not indices:
        return []
    blocks = np.array_split(np.array(indices), min(n_chains, len(indices)))
    mid = 0.5 * (eps[0] + eps[-1])
    out = []
    for b in blocks:
        b = [int(i) for i in b]
        out.append(b if eps[b].mean() <= mid else b[::-1])
    return out


def sweep(problem, out_dir, points: int | None = None, workers: int | None = None,
          resume: bool = False, scheduler=None, progress: bool = True) -> ParetoResult:
    """Sweep the front of every admissible phase count; write pareto.csv/json to ``out_dir``.

    Parameters
    ----------
    problem : Problem
        The problem; its ``pareto:`` section (if any) sets points, ratio span and counts.
    out_dir : path
        Folder of ``points.jsonl`` (the journal), ``pareto.csv`` and ``pareto.json``.
    points : int, optional
        ε values per phase count (end points included); overrides ``pareto.points``.
    workers : int, optional
        Local worker processes (default: every core; 1 runs in this process).
    resume : bool
        Keep the journal's finished points and solve only the rest.
    scheduler : str or distributed.Client, optional
        Run the tasks on this Dask cluster instead of local processes.
    """
    if not problem.free_lengths():
        raise ProblemError(f"{problem.name}: design: a front needs a free length (give one a "
                           f"range, e.g. l3: {{lower: 30, upper: 90}}); every length is fixed")
    if problem.objective.minimize not in ("ripple", "-ratio"):
        raise ProblemError(f"{problem.source}: objective.minimize: a front is of the least "
                           f"ripple; give minimize: ripple (got {problem.objective.minimize})")
    axis = axis_of(problem)
    if not axis.is_ratio and (problem.eccentricity_range is not None or
                              problem.objective.robust == "worst_case"):
        raise ProblemError(f"{problem.source}: pareto.against: a front against {axis.name} "
                           f"is held at listed eccentricities of a nominal design, not over a "
                           f"regulation interval or a tolerance box")
    run = _Sweep(problem, out_dir, points, workers, resume, scheduler, progress)
    return run.run()


class _Sweep:
    """One sweep's state: the journal of finished points, the chains of ε points in flight,
    the executor and the progress bar; each step a method."""

    def __init__(self, problem, out_dir, points, workers, resume, scheduler, progress):
        self.t0 = time.perf_counter()
        self.problem, self.scheduler = with_axis(problem), scheduler
        self.axis = axis_of(problem)
        self.ends = ("least_ripple", self.axis.end)
        self.section = problem.sections.get("pareto") or ParetoSection(source=problem.source)
        self.n_points = points or self.section.points or DEFAULT_POINTS
        self.counts = list(self.section.counts or problem.counts())
        self.settings = {"problem": problem.source,
                         "problem_sha256": hashlib.sha256(repr(problem).encode()).hexdigest(),
                         "points": self.n_points, "counts": self.counts,
                         "ratio_lower": self.section.ratio_lower,
                         "ratio_upper": self.section.ratio_upper,
                         "refine": asdict(self.section.refine)}
        if not self.axis.is_ratio:      # a ratio front's settings stay as they were
            self.settings["against"] = self.axis.name
        self.out = Path(out_dir)
        self.journal = Journal(self.out / "points.jsonl")
        self.done = {tuple(r["key"]): r for r in self.journal.start(self.settings, resume)}
        _reverify(self.problem, self.done, self.journal)
        self.n_resumed = len(self.done)
        self.ex = _executor(workers, scheduler)
        self.n_workers = local_processes(workers)
        self.n_chains = max(2, -(-self.n_workers // max(1, len(self.counts))))
        from tqdm import tqdm
        refined = sum(1 for r in self.done.values() if (r.get("round") or 0) >= 1)
        self.bar = tqdm(total=len(self.counts) * (self.n_points + 2) + refined,
                        initial=self.n_resumed,
                        desc="ends and uniform pass", unit="point", file=sys.stderr,
                        disable=None if progress else True, dynamic_ncols=True)
        #: off a terminal the bar is silent: one line a round says where the sweep is
        self.pipe = progress and not is_terminal(sys.stderr)
        self.say(f"the ends and the uniform pass: {self.bar.total - self.n_resumed} points "
                 f"planned ({len(self.counts)} phase count(s) × {self.n_points} ε values and "
                 f"2 ends)" + (f", {self.n_resumed} resumed" if self.n_resumed else ""))
        self.running: dict = {}       # future -> (count, chain, None (an end) or "round")
        self.chains: dict = {}        # (count, j) -> {"order", "pos", "start", "eps", "ends"}
        self.screened: dict = {}      # count -> ScreenedCount (the box screened once)
        self.rebuilt = -float("inf")  # when pareto.csv/json were last rebuilt

    def run(self) -> ParetoResult:
        interrupted = True
        try:
            for n in self.counts:
                missing = [k for k in self.ends if (n, k) not in self.done]
                for k in missing:
                    self.running[self.ex.submit(_worker().solve_end, self.problem, n, k)] = (n, None)
                if not missing:
                    self.open_count(n)
                    self.advance(n)
            while self.running or self.advance_hypervolume():
                raise_if_terminated()
                for fut in self.ex.wait_any(list(self.running)):
                    count, j = self.running.pop(fut)
                    self.finish(fut.result())
                    if j is None:
                        if all((count, k) in self.done for k in self.ends):
                            self.open_count(count)
                    elif j != "round":
                        self.submit_chain(count, j)
                    if all(c != count for c, _ in self.running.values()) and \
                            all((count, k) in self.done for k in self.ends):
                        self.advance(count)
                    if time.perf_counter() - self.rebuilt >= REBUILD_EVERY_S:
                        _rebuild(self.problem, self.done, self.out, self.settings)
                        self.rebuilt = time.perf_counter()
            interrupted = False
        finally:
            self.bar.close()
            self.ex.close(interrupted)
        result = _rebuild(self.problem, self.done, self.out, self.settings, write=False)
        self.say(f"done: {len(self.done)} solves journalled ({self.n_resumed} resumed)")
        result.run.update({"wall_time_s": time.perf_counter() - self.t0,
                           "resumed_points": self.n_resumed,
                           "workers": "dask" if self.scheduler is not None else self.n_workers})
        write_front(result, self.out)
        return result

    def finish(self, rec: dict) -> None:
        rec["finished_s"] = time.perf_counter() - self.t0      # since this run started
        self.done[tuple(rec["key"])] = rec
        self.journal.append(rec)
        self.bar.update(1)

    def submit_chain(self, count: int, j: int) -> None:
        """The chain's next unfinished point, warm-started from its last feasible design."""
        c = self.chains[(count, j)]
        while c["pos"] < len(c["order"]) and (count, c["order"][c["pos"]]) in self.done:
            prev = self.done[(count, c["order"][c["pos"]])]
            if prev["feasible"]:
                c["start"], c["warm"] = prev["design"], prev.get("warm")
            c["pos"] += 1
        if c["pos"] >= len(c["order"]):
            return
        i = c["order"][c["pos"]]
        fallbacks = [e["design"] for e in c["ends"] if e["design"] != c["start"]]
        eps = float(c["eps"][i])
        fut = self.ex.submit(_worker().solve_point, self.problem, count, i, eps, c["start"],
                             fallbacks, self.seeds(count, eps, [c["start"]]), [],
                             {"round": 0}, self.known(count), c.get("warm"))
        self.running[fut] = (count, j)

    def known(self, count: int) -> list[dict]:
        """The count's verified ends (design, δ and gain): every ε point weighs them as they
        are where one would beat its polishes."""
        ends = [self.done.get((count, k)) for k in self.ends]
        return [{"design": e["design"], "delta": e["delta"], "gain": refine.gain(e)}
                for e in ends if e and e.get("feasible") and e.get("design")]

    def seeds(self, count: int, epsilon: float, near: list[dict]) -> list[dict]:
        """The screening's best basins that reach ``epsilon`` (``solver.basins`` of them),
        away from the designs in ``near``; the count is screened on first use."""
        if count not in self.screened:
            try:
                from optdesign.fronts.seeds import ScreenedCount

                self.screened[count] = ScreenedCount.of(self.problem, count)
            except (OptDesignError, RuntimeError, ValueError, ArithmeticError):
                self.screened[count] = None     # no screening: the chains' own starts
        screened = self.screened[count]
        return [] if screened is None else \
            screened.seeds(epsilon, self.problem.solver.basins, near)

    def advance(self, count: int) -> None:
        """The count's uniform pass (or last round) is finished: submit the first round of
        :func:`refine.plan` that is not finished yet (re-solves of dominated points, refined
        ε values). Each round is planned from the earlier rounds' records alone, so a resumed
        sweep plans the same rounds and solves only what the journal lacks."""
        if any(c == count for c, _ in self.running.values()):
            return                      # the count's current pass is still running
        lengths = list(self.problem.model.lengths)
        mine = [r for (n, tag), r in self.done.items() if n == count and not isinstance(tag, str)]
        if not mine:
            return
        for r in range(1, refine.MAX_ROUNDS + 1):
            earlier = [rec for rec in mine if (rec.get("round") or 0) < r]
            first = max(self.n_points, 1 + max(rec["key"][1] for rec in earlier))
            tasks = refine.plan(earlier, lengths, self.section.refine, first)
            if not tasks:
                return
            missing = [t for t in tasks if (count, t.index) not in self.done]
            if not missing:
                continue
            self.submit_round([
                (count, t, [] if t.replaces is not None else
                 self.seeds(count, t.epsilon, [t.start, *t.also]),
                 {"round": r} | ({"replaces": t.replaces} if t.replaces is not None else {}))
                for t in missing])
            return

    def say(self, text: str) -> None:
        """Name the sweep's stage: the bar's label, and a line of its own off a terminal."""
        self.bar.set_description_str(text.split(":")[0], refresh=False)
        if self.pipe:
            print(f"pareto {time.perf_counter() - self.t0:7.1f} s: {text}", file=sys.stderr,
                  flush=True)

    def submit_round(self, jobs: list[tuple]) -> None:
        """Submit a round's solves, (count, task, seeds, journal tags) each."""
        self.bar.total += len(jobs)
        self.bar.refresh()
        r = jobs[0][3].get("round", 0) if jobs else 0
        counts = sorted({count for count, *_ in jobs})
        again = sum(1 for *_, tags in jobs if tags.get("replaces") is not None)
        kind = "hypervolume round" if r > refine.MAX_ROUNDS else "round"
        number = r - refine.MAX_ROUNDS if r > refine.MAX_ROUNDS else r
        where = "every count" if r > refine.MAX_ROUNDS else \
            ", ".join(f"n = {n}" for n in counts)
        self.say(f"{kind} {number} ({where}): {len(jobs)} points planned"
                 + (f", {again} of them re-solves" if again else "")
                 + f"; {len(self.done)} of {self.bar.total} done")
        for count, t, seeds, tags in jobs:
            fut = self.ex.submit(_worker().solve_point, self.problem, count, t.index, t.epsilon,
                                 t.start, [], seeds, t.also, tags, self.known(count), t.warm)
            self.running[fut] = (count, "round")

    def advance_hypervolume(self) -> bool:
        """Every count's own rounds are finished: submit the first hypervolume round
        (:func:`refine.plan_hypervolume`, over the front of every count) not finished yet;
        False when none is left. Planned from the earlier rounds' records alone, as
        :meth:`advance`."""
        grid_records = [r for (_, tag), r in self.done.items() if not isinstance(tag, str)]
        lengths = list(self.problem.model.lengths)
        for r in range(refine.MAX_ROUNDS + 1,
                       refine.MAX_ROUNDS + refine.HYPERVOLUME_ROUNDS + 1):
            earlier = [rec for rec in grid_records if (rec.get("round") or 0) < r]
            tasks = refine.plan_hypervolume(earlier, lengths, self.section.refine,
                                            self.n_points)
            if not tasks:
                return False
            missing = [t for t in tasks if (t.count, t.task.index) not in self.done]
            if not missing:
                continue
            # between two verified neighbours of a front the screening has seeded at every
            # uniform point already: polished from the neighbours alone
            self.submit_round([(ct.count, ct.task, [], {"round": r} | (
                {"replaces": ct.task.replaces} if ct.task.replaces is not None else {}))
                for ct in missing])
            return True
        return False

    def open_count(self, count: int) -> None:
        """Both ends of a count are known: lay out its ε grid and start its chains."""
        ends = {k: self.done[(count, k)] for k in self.ends}
        lo_end, hi_end = (ends[k] for k in self.ends)
        if not lo_end["feasible"]:
            return
        eps = grid(self.section, ends, self.n_points)
        if len(eps) == 0:
            return
        interior = list(range(len(eps)))
        if eps[0] == refine.gain(lo_end) and (count, 0) not in self.done:
            self.finish(_worker().copy_end(lo_end, 0) | {"round": 0})
        if eps[0] == refine.gain(lo_end):
            interior.remove(0)
        last = len(eps) - 1
        if last > 0 and hi_end["feasible"] and eps[-1] == refine.gain(hi_end):
            if (count, last) not in self.done:
                self.finish(_worker().copy_end(hi_end, last) | {"round": 0})
            interior.remove(last)
        ok_ends = [e for e in (lo_end, hi_end) if e["feasible"]]
        for j, order in enumerate(_chains(interior, eps, self.n_chains)):
            up = order[0] <= order[-1]
            start = lo_end if up or not hi_end["feasible"] else hi_end
            self.chains[(count, j)] = {"order": order, "pos": 0, "start": start["design"],
                                       "warm": start.get("warm"), "eps": eps, "ends": ok_ends}
            self.submit_chain(count, j)


#: a resumed record's figures must equal its design's exact ones to this share
RESUME_REL = 1e-9


def _reverify(problem, done: dict, journal: Journal) -> None:
    """Every resumed record checked before it enters a front: one that is not a feasible
    optimum is solved again (:func:`~optdesign.fronts.store.to_solve_again`: removed from
    ``done``), and every feasible record's design is evaluated exactly again: its δ, ratio
    and least transmission angle must be the record's, and the design must meet the
    problem's constraints. An edited or foreign record is refused (exit 2) with its line;
    the journal is left as it is."""
    to_solve_again(done)
    for key, rec in done.items():
        where = f"{journal.path}: line {journal.line_of.get(key, '?')}"
        design = dict(rec["design"])
        design.setdefault(problem.model.count_variable, rec["count"])
        try:
            ver = verify(problem, design)
        except (OptDesignError, KeyError, TypeError, ValueError, ArithmeticError) as exc:
            raise ProblemError(f"{where}: the record's design cannot be evaluated ({exc}); "
                               f"run without --resume to start afresh") from None
        figures = {"delta": ver.delta, "ratio": ver.ratio,
                   "min_transmission_angle_deg": ver.min_angle_deg}
        wrong = [name for name, exact in figures.items() if exact is None or
                 rec.get(name) is None or
                 abs(rec[name] - exact) > RESUME_REL * max(1.0, abs(exact))]
        if not ver.feasible or wrong:
            what = ", ".join(f"{n} {rec.get(n)!r} recorded, {figures[n]!r} exact"
                             for n in wrong) or "the design breaks a constraint"
            raise ProblemError(f"{where}: the record does not match its design ({what}); "
                               f"it is left as it is: run without --resume to start afresh")


def _rebuild(problem, done: dict, out: Path, settings: dict,
             write: bool = True) -> ParetoResult:
    """The front from every finished record; with ``write``, pareto.csv/json rewritten
    atomically (the last rebuild writes them once, with the run's wall time)."""
    axis = axis_of(problem)
    section = problem.sections.get("pareto") or ParetoSection()
    records = refine.visible(list(done.values()), list(problem.model.lengths))
    model, columns = problem.model, result_columns(problem)
    points = frame(records, list(model.lengths), axis, model.count_variable, list(columns))
    # the midrange δ of an output at rest once a turn (ω_min = 0): 2, the largest there is
    at_rest = 2.0 if problem.objective.ripple == "midrange" else None
    overall, per_count = evaluate(points, axis, section.refine.delta_resolution, at_rest)
    ends = [r for r in records if isinstance(r["key"][1], str)]
    result = ParetoResult(points, overall, per_count, run=dict(settings), ends=ends,
                          count_name=model.count_variable, criteria_columns=columns)
    if write:
        write_front(result, out)
    return result

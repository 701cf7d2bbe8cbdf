"""An atlas computed: every cell solved once, on local processes or a Dask cluster, each
finished cell appended to the journal ``cells.jsonl`` at once (the Pareto sweep's
:class:`~optdesign.fronts.store.Journal`), so a killed run or a lost worker loses no finished
cell and ``--resume`` solves only the rest, to the same atlas.

Continuation: the cells are walked in *chains* along one axis (the phase count when it is
an axis: the optimum of n − 1 often lies in the best basin of n), one cell of a chain at a
time, and every cell is screened with the optima of its neighbours solved so far (one step
along any axis). A cell starts once a neighbour is solved, so the work spreads from the
first cell along the chains and across them. Every cell shares the regulated length (1), so
a neighbour's optimum needs no scaling to serve as a start; where it breaks the cell's rules
the screening filters it out and the cell's own screening starts the solve.

Repairs: a cell's solve is global by screening, not by proof, and two neighbours can end in
different basins. Along a floor axis (transmission angle, pin radius, ratio) the looser cell's
least δ is at most its stricter neighbour's; where the atlas says otherwise, the looser cell is
solved again with that neighbour's optimum among its starts (at most MAX_REPAIR_ROUNDS rounds)
and keeps the better verified optimum.
"""
from __future__ import annotations

import hashlib
import json
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from optdesign.atlas.spec import AtlasSpec, Cell
from optdesign.atlas.worker import solve_cell
from optdesign.errors import OptDesignError, ProblemError
from optdesign.fronts.store import Journal, to_solve_again
from optdesign.lifetime import raise_if_terminated
from optdesign.limits import local_processes
from optdesign.solver import verify

#: a resumed record's δ and ratio must match its design's exact figures to this (relative)
RESUME_REL = 1e-9
#: cells in flight per worker: few, so that a cell submitted later sees its neighbours solved
IN_FLIGHT_PER_WORKER = 2
JOURNAL = "cells.jsonl"
#: the rules a stricter value only narrows: a design that meets the stricter value meets the
#: looser, so a cell's least δ is at most that of its neighbour with the stricter value
FLOORS = ("min_transmission_angle_deg", "min_pin_radius", "min_ratio")
#: a looser cell's δ above its stricter neighbour's by more than this (relative) is repaired
REPAIR_TOL = 1e-7
MAX_REPAIR_ROUNDS = 3


@dataclass
class AtlasResult:
    """A computed atlas: its file and one journal record per cell (by cell index)."""

    spec: AtlasSpec
    records: list[dict]
    run: dict = field(default_factory=dict)

    @property
    def n_feasible(self) -> int:
        return sum(1 for r in self.records if r["feasible"])


def chain_axis(spec: AtlasSpec) -> str:
    """The axis the chains walk along: the phase count when it is one, else the first."""
    return "phases" if "phases" in spec.axes else next(iter(spec.axes))


def chains(spec: AtlasSpec) -> list[list[Cell]]:
    """The cells in chains along :func:`chain_axis`, each from the axis's first value."""
    k = list(spec.axes).index(chain_axis(spec))
    groups: dict = {}
    for cell in spec.cells():
        groups.setdefault(cell.position[:k] + cell.position[k + 1:], []).append(cell)
    return [sorted(g, key=lambda c: c.position[k]) for g in groups.values()]


def adjacent(position: tuple) -> list[tuple]:
    """The positions one step from ``position`` along any axis (some may lie off the grid:
    no cell is there)."""
    out = []
    for axis in range(len(position)):
        for step in (-1, 1):
            pos = list(position)
            pos[axis] += step
            out.append(tuple(pos))
    return out


def solved_at(cells: list[Cell], done: dict) -> dict:
    """The records of the solved cells by their positions on the grid."""
    return {cells[i].position: r for i, r in done.items()}


def neighbours_of(cell: Cell, by_position: dict) -> list[dict]:
    """The optima of the solved feasible cells one step from ``cell`` along any axis."""
    return [by_position[p]["design"] for p in adjacent(cell.position)
            if p in by_position and by_position[p]["feasible"]]


def settings_of(spec: AtlasSpec) -> dict:
    """What a journal must have been written for to be resumed."""
    text = json.dumps({"axes": spec.axes, "fixed": spec.fixed, "base": spec.base},
                      sort_keys=True, default=str)
    # the axes' order numbers the cells: a file with its axes reordered is another grid
    return {"atlas": spec.name, "atlas_sha256": hashlib.sha256(text.encode()).hexdigest(),
            "axes": list(spec.axes), "cells": len(spec.cells())}


def run_atlas(spec: AtlasSpec, out_dir, workers: int | None = None, resume: bool = False,
              scheduler=None, progress: bool = True) -> AtlasResult:
    """Solve every cell of ``spec``; the journal ``cells.jsonl`` in ``out_dir``.

    Parameters
    ----------
    spec : AtlasSpec
        The atlas (:func:`optdesign.atlas.spec.load_atlas`).
    out_dir : path
        Folder of the journal.
    workers : int, optional
        Local worker processes (default: every core; 1 runs in this process).
    resume : bool
        Keep the journal's finished cells (each re-verified) and solve only the rest.
    scheduler : str or distributed.Client, optional
        Run the cells on this Dask cluster instead of local processes.
    progress : bool
        A progress bar on stderr.
    """
    return _Run(spec, Path(out_dir), workers, resume, scheduler, progress).run()


class _Run:
    """One run's state: the journal's records, the chains, the executor, the progress bar."""

    def __init__(self, spec, out, workers, resume, scheduler, progress):
        from optdesign.fronts.sweep import _executor    # the Pareto sweep's executors
        self.t0 = time.perf_counter()
        self.spec, self.scheduler = spec, scheduler
        self.cells = spec.cells()
        self.journal = Journal(out / JOURNAL)
        self.done: dict[int, dict] = {}
        for rec in self.journal.start(settings_of(spec), resume):
            index = _checked_index(rec, self.cells, self.journal)
            self.done[index] = better(self.done.get(index), rec)
        _reverify(spec, self.cells, self.done, self.journal)
        self.n_resumed = len(self.done)
        self.ex = _executor(workers, scheduler)
        self.n_workers = _n_workers(self.ex, workers)
        self.limit = max(2, IN_FLIGHT_PER_WORKER * self.n_workers)
        self.chains = chains(spec)
        self.running: dict = {}              # future -> chain number, or "repair"
        self.tried: set = set()              # (cell, neighbour cell) repairs already run
        self.n_repairs = 0
        from tqdm import tqdm
        self.bar = tqdm(total=len(self.cells), initial=self.n_resumed, desc="atlas",
                        unit="cell", file=sys.stderr, disable=None if progress else True,
                        dynamic_ncols=True)

    def run(self) -> AtlasResult:
        interrupted = True
        try:
            for round_ in range(MAX_REPAIR_ROUNDS + 1):
                if round_ and not self.repair(round_):
                    break
                self.fill()
                while self.running:
                    raise_if_terminated()
                    for fut in self.ex.wait_any(list(self.running)):
                        self.running.pop(fut)
                        self.finish(fut.result())
                    self.fill()
            interrupted = False
        finally:
            self.bar.close()
            self.ex.close(interrupted)
        records = [self.done[c.index] for c in self.cells]
        return AtlasResult(self.spec, records, run={
            "wall_time_s": time.perf_counter() - self.t0, "cells": len(self.cells),
            "resumed_cells": self.n_resumed, "chain_axis": chain_axis(self.spec),
            "repairs": self.n_repairs,
            "workers": "dask" if self.scheduler is not None else self.n_workers})

    def fill(self) -> None:
        """Submit the next unsolved cell of every chain with none in flight, up to the limit
        of cells in flight. A cell waits until a neighbour is solved (so that it is screened
        with that neighbour's optimum): the work spreads from the first cell along the
        chains and across them; only when nothing is in flight does a cell start alone."""
        busy = set(self.running.values())
        by_position = solved_at(self.cells, self.done)
        waiting = None
        for j, chain in enumerate(self.chains):
            if len(self.running) >= self.limit:
                return
            if j in busy:
                continue
            cell = next((c for c in chain if c.index not in self.done), None)
            if cell is None:
                continue
            if not any(p in by_position for p in adjacent(cell.position)):
                waiting = waiting or (j, cell)
                continue
            self.submit(j, cell, by_position)
        if not self.running and waiting is not None:
            self.submit(*waiting, by_position)

    def submit(self, j: int, cell: Cell, by_position: dict) -> None:
        fut = self.ex.submit(solve_cell, self.spec.problem(cell), cell.index,
                             self.spec.values_of(cell), neighbours_of(cell, by_position))
        self.running[fut] = j

    def repair(self, round_: int) -> int:
        """Submit this round's repairs (:func:`looser_than_stricter`); how many."""
        todo = [(i, nb) for i, nb in looser_than_stricter(self.spec, self.cells, self.done)
                if (i, nb["cell"]) not in self.tried]
        by_position = solved_at(self.cells, self.done)
        for index, nb in todo:
            self.tried.add((index, nb["cell"]))
            cell = self.cells[index]
            starts = [nb["design"]] + [d for d in neighbours_of(cell, by_position)
                                       if d != nb["design"]]
            fut = self.ex.submit(solve_cell, self.spec.problem(cell), index,
                                 self.spec.values_of(cell), starts, round_)
            self.running[fut] = "repair"
        self.n_repairs += len(todo)
        self.bar.total += len(todo)
        self.bar.refresh()
        return len(todo)

    def finish(self, rec: dict) -> None:
        rec["finished_s"] = time.perf_counter() - self.t0
        self.done[rec["cell"]] = better(self.done.get(rec["cell"]), rec)
        self.journal.append(rec)
        self.bar.update(1)


def better(old: dict | None, new: dict) -> dict:
    """The record of a cell to keep: ``new`` unless ``old`` is a verified optimum that
    ``new`` does not improve (a repair that found nothing better leaves the cell as it was)."""
    if old is None or not old["feasible"]:
        return new if new["feasible"] or old is None else old
    return new if new["feasible"] and new["delta"] < old["delta"] else old


def looser_than_stricter(spec: AtlasSpec, cells: list[Cell], done: dict) -> list:
    """(cell index, the neighbour's record) for every solved cell whose δ is worse than that
    of a neighbour one step stricter along a floor axis (:data:`FLOORS`), or which has no
    optimum where that neighbour has one; the best such neighbour per cell."""
    by_position = solved_at(cells, done)
    found: dict = {}
    for k, name in enumerate(spec.axes):
        if name not in FLOORS:
            continue
        for index, rec in done.items():
            for step in (-1, 1):
                pos = list(cells[index].position)
                pos[k] += step
                nb = by_position.get(tuple(pos))
                if nb is None or not nb["feasible"] or nb["values"][name] <= \
                        rec["values"][name]:
                    continue
                worse = not rec["feasible"] or \
                    nb["delta"] < rec["delta"] - REPAIR_TOL * max(1.0, rec["delta"])
                if worse and (index not in found or nb["delta"] < found[index]["delta"]):
                    found[index] = nb
    return sorted(found.items())


def _n_workers(ex, workers) -> int:
    client = getattr(ex, "client", None)
    if client is not None:
        try:
            return max(1, len(client.scheduler_info()["workers"]))
        except (OSError, KeyError, TypeError):
            return 2
    return local_processes(workers)


def _line_of(journal: Journal, rec: dict) -> str:
    """Where a resumed record stands: the journal and its line."""
    return f"{journal.path}: line {journal.line_of.get(tuple(rec['key']), '?')}"


def _checked_index(rec: dict, cells: list[Cell], journal: Journal) -> int:
    """The cell a resumed record is of, checked against its key and the grid."""
    where = _line_of(journal, rec)
    index = rec.get("cell")
    if not isinstance(index, int) or not 0 <= index < len(cells) or rec["key"][1] != index \
            or not isinstance(rec.get("values"), dict):
        raise ProblemError(f"{where}: the record names no cell of this atlas; run without "
                           f"--resume to start afresh")
    return index


def _reverify(spec: AtlasSpec, cells: list[Cell], done: dict, journal: Journal) -> None:
    """Every resumed record checked: one that is not a feasible optimum (an infeasible or
    failed cell, a status that is no known verdict) is solved again
    (:func:`~optdesign.fronts.store.to_solve_again`: removed from ``done``), and every
    feasible record's design is evaluated exactly and its figures compared: a journal is
    trusted only where its numbers are its designs' own."""
    for index, rec in done.items():
        where = _line_of(journal, rec)
        cell = cells[index]
        if rec["values"] != spec.values_of(cell) or rec["count"] != spec.values_of(cell)[
                "phases"]:
            raise ProblemError(f"{where}: the record's axes' values are not its cell's; run "
                               f"without --resume to start afresh")
    to_solve_again(done)
    for index, rec in done.items():
        where = _line_of(journal, rec)
        cell = cells[index]
        try:
            ver = verify(spec.problem(cell), dict(rec["design"]))
        except (OptDesignError, KeyError, TypeError, ValueError, ArithmeticError) as exc:
            raise ProblemError(f"{where}: the record's design cannot be evaluated ({exc}); "
                               f"run without --resume to start afresh") from None
        exact = {"delta": ver.delta, "ratio": ver.ratio}
        wrong = [n for n, v in exact.items() if v is None or not isinstance(
            rec.get(n), (int, float)) or abs(rec[n] - v) > RESUME_REL * max(1.0, abs(v))]
        if not ver.feasible or wrong:
            raise ProblemError(f"{where}: the record does not match its design; it is left "
                               f"as it is: run without --resume to start afresh")

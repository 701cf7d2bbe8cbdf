"""An atlas computed: every cell solved once, on local processes or a Dask cluster, each
finished cell appended to the journal ``cells.jsonl`` at once (the Pareto sweep's
:class:`~optdesign.fronts.store.Journal`), so a killed run or a lost worker loses no finished
cell and ``--resume`` solves only the rest, to the same atlas.

Continuation: the cells are walked in *chains* along one axis (the phase count when it is
an axis: the optimum of n − 1 often lies in the best basin of n), one cell of a chain at a
time, and every cell is screened with the optima of its neighbours solved so far (one step
along any axis). Every cell shares the regulated length (1), so a neighbour's optimum needs
no scaling to serve as a start; where it breaks the cell's rules the screening filters it out
and the cell's own screening starts the solve.
"""
from __future__ import annotations

import hashlib
import json
import os
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from optdesign.atlas.spec import AtlasSpec, Cell
from optdesign.atlas.worker import solve_cell
from optdesign.errors import OptDesignError, ProblemError
from optdesign.fronts.store import Journal
from optdesign.lifetime import raise_if_terminated
from optdesign.solver import verify

#: a resumed record's δ and ratio must match its design's exact figures to this (relative)
RESUME_REL = 1e-9
#: cells in flight per worker: few, so that a cell submitted later sees its neighbours solved
IN_FLIGHT_PER_WORKER = 2
JOURNAL = "cells.jsonl"


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


def neighbours_of(cell: Cell, by_position: dict) -> list[dict]:
    """The optima of the solved feasible cells one step from ``cell`` along any axis."""
    out = []
    for axis in range(len(cell.position)):
        for step in (-1, 1):
            pos = list(cell.position)
            pos[axis] += step
            rec = by_position.get(tuple(pos))
            if rec is not None and rec["feasible"]:
                out.append(rec["design"])
    return out


def settings_of(spec: AtlasSpec) -> dict:
    """What a journal must have been written for to be resumed."""
    text = json.dumps({"axes": spec.axes, "fixed": spec.fixed, "base": spec.base},
                      sort_keys=True, default=str)
    return {"atlas": spec.name, "atlas_sha256": hashlib.sha256(text.encode()).hexdigest(),
            "cells": len(spec.cells())}


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
            self.done[_checked_index(rec, self.cells, self.journal)] = rec
        _reverify(spec, self.cells, self.done, self.journal)
        self.n_resumed = len(self.done)
        self.ex = _executor(workers, scheduler)
        self.n_workers = _n_workers(self.ex, workers)
        self.limit = max(2, IN_FLIGHT_PER_WORKER * self.n_workers)
        self.chains = chains(spec)
        self.running: dict = {}              # future -> chain number
        from tqdm import tqdm
        self.bar = tqdm(total=len(self.cells), initial=self.n_resumed, desc="atlas",
                        unit="cell", file=sys.stderr, disable=None if progress else True,
                        dynamic_ncols=True)

    def run(self) -> AtlasResult:
        interrupted = True
        try:
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
            "workers": "dask" if self.scheduler is not None else self.n_workers})

    def fill(self) -> None:
        """Submit the next unsolved cell of every chain with none in flight, in order, up
        to the limit of cells in flight."""
        busy = set(self.running.values())
        for j, chain in enumerate(self.chains):
            if len(self.running) >= self.limit:
                return
            if j in busy:
                continue
            cell = next((c for c in chain if c.index not in self.done), None)
            if cell is None:
                continue
            by_position = {self.cells[i].position: r for i, r in self.done.items()}
            fut = self.ex.submit(solve_cell, self.spec.problem(cell), cell.index,
                                 self.spec.values_of(cell), neighbours_of(cell, by_position))
            self.running[fut] = j

    def finish(self, rec: dict) -> None:
        rec["finished_s"] = time.perf_counter() - self.t0
        self.done[rec["cell"]] = rec
        self.journal.append(rec)
        self.bar.update(1)


def _n_workers(ex, workers) -> int:
    client = getattr(ex, "client", None)
    if client is not None:
        try:
            return max(1, len(client.scheduler_info()["workers"]))
        except (OSError, KeyError, TypeError):
            return 2
    return workers or os.cpu_count() or 1


def _checked_index(rec: dict, cells: list[Cell], journal: Journal) -> int:
    """The cell a resumed record is of, checked against its key and the grid."""
    where = f"{journal.path}: line {journal.line_of.get(tuple(rec['key']), '?')}"
    index = rec.get("cell")
    if not isinstance(index, int) or not 0 <= index < len(cells) or rec["key"][1] != index \
            or not isinstance(rec.get("values"), dict):
        raise ProblemError(f"{where}: the record names no cell of this atlas; run without "
                           f"--resume to start afresh")
    return index


def _reverify(spec: AtlasSpec, cells: list[Cell], done: dict, journal: Journal) -> None:
    """Every resumed feasible record's design evaluated exactly and its figures compared: a
    journal is trusted only where its numbers are its designs' own."""
    for index, rec in done.items():
        where = f"{journal.path}: line {journal.line_of.get(tuple(rec['key']), '?')}"
        cell = cells[index]
        if rec["values"] != spec.values_of(cell) or rec["count"] != spec.values_of(cell)[
                "phases"]:
            raise ProblemError(f"{where}: the record's axes' values are not its cell's; run "
                               f"without --resume to start afresh")
        if not rec["feasible"]:
            continue
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

"""The unit of work of an atlas: one cell solved and verified, as a journal record.

Runs in worker processes or on Dask workers: it takes the cell's problem (a frozen, picklable
object) and the optima of its solved neighbours, and returns plain data.
"""
from __future__ import annotations

import time

from optdesign.fronts.worker import criteria_columns
from optdesign.solver import solve_phase


def solve_cell(problem, index: int, values: dict, neighbours: list[dict],
               repair: int = 0) -> dict:
    """Solve one cell; its record for the journal.

    Parameters
    ----------
    problem : Problem
        The cell's problem (lengths relative to the regulated one, which is 1).
    index : int
        The cell's index in the atlas's grid.
    values : dict
        The axes' values at the cell (for the record).
    neighbours : list of dict
        Optima of solved neighbouring cells: screened with the box (continuation along each
        axis); each ranks first when it meets this cell's rules, and is filtered out with
        the other screened designs when it does not.
    repair : int
        0 for the cell's first solve; k for its re-solve in the k-th round of repairs
        (:func:`optdesign.atlas.run.looser_than_stricter`).
    """
    t0 = time.perf_counter()
    count = int(values["phases"])
    res = solve_phase(problem, count, workers=1, neighbours=list(neighbours))
    feasible = res.status == "optimal"
    design = {k: float(v) for k, v in (res.design or {}).items()} if feasible else {}
    if design:
        design[problem.model.count_variable] = count
    columns = criteria_columns(problem, design) if feasible else {}
    # an infeasible cell names the rule out of reach where the solver measured it
    rule = (res.reachable or {}).get("constraint") or res.binding
    binding = [a["name"] for a in res.active] if feasible else [rule] if rule else []
    return {"key": [count, index], "count": count, "kind": "cell", "cell": index,
            "values": dict(values), "status": res.status, "feasible": feasible,
            "design": design, "delta": res.delta if feasible else None,
            "ratio": res.ratio if feasible else None, "epsilon": None,
            "min_transmission_angle_deg": res.min_transmission_angle_deg if feasible else None,
            **columns, "binding": "; ".join(binding), "message": res.message,
            "reachable": res.reachable or None, "iterations": res.iterations,
            "starts": len(res.starts), "neighbours": len(neighbours), "repair": repair,
            "time_s": time.perf_counter() - t0}

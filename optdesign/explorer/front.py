"""A finished front shown beside the explorer: its verified points, each loadable.

``--front DIR`` names the folder of an ``optdesign pareto`` run; its ``pareto.csv`` is read
(a regular file of at most 1 MiB, as ``--design`` reads one) and every point whose status is
``optimal`` is drawn, δ against the quantity the front trades it against (the ratio unless
the problem's ``pareto.against`` names another). A click loads the point's design as
``--design DIR/pareto.csv --point K`` would (:mod:`optdesign.commands.design_source`).
"""
from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass
from pathlib import Path

from optdesign.errors import UsageError, shown

#: a front's table in its folder
FRONT_FILE = "pareto.csv"


@dataclass(frozen=True)
class Front:
    """The front's file, the axis it trades δ against, and its verified points (``point``:
    the row number from 1, as ``--point`` counts; ``x``, ``delta``, ``count``)."""

    path: Path
    axis: str
    rows: list


def front_points(folder, problem) -> Front:
    """The :class:`Front` of ``folder`` (or of the pareto.csv named) for ``problem``;
    UsageError naming ``--front`` when it has no table or no verified point."""
    from optdesign.commands.design_source import file_text

    folder = Path(folder)
    path = folder / FRONT_FILE if folder.is_dir() else folder
    where = f"--front {shown(str(folder))}"
    if not path.is_file():
        raise UsageError(f"{where}: has no {FRONT_FILE} (the folder of a finished "
                         f"optdesign pareto run)")
    section = problem.sections.get("pareto")
    axis = getattr(section, "against", "ratio") or "ratio"
    count_key = problem.model.count_variable
    rows = []
    for k, row in enumerate(csv.DictReader(io.StringIO(file_text(path, where))), start=1):
        if row.get("status") != "optimal":
            continue
        try:
            x, delta = float(row.get(axis, "")), float(row.get("delta", ""))
            count = int(float(row.get(count_key) or row.get("count") or "nan"))
        except ValueError:
            continue
        if math.isfinite(x) and math.isfinite(delta):
            rows.append({"point": k, "x": x, "delta": delta, "count": count,
                         "count_key": count_key})
    if not rows:
        raise UsageError(f"{where}: {shown(str(path))} holds no verified point (status "
                         f"optimal)")
    return Front(path, axis, rows)

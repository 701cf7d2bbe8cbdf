"""An atlas as a table and as a document: ``atlas.csv`` (one row a cell) and ``atlas.json``
(the same cells with the atlas's axes, the values held fixed and every key's unit), each
written atomically."""
from __future__ import annotations

from pathlib import Path

from optdesign.outputs.atomic import atomic_write_json, atomic_write_text
from optdesign.outputs.units import COUNT, stamped

RELATIVE = "- (length / the regulated length {reg})"
#: the units of the atlas's own keys (the lengths are relative)
ATLAS_UNITS = {"cell": "- (the cell's index in the grid, the last axis fastest)",
               "neighbours": "- (count of solved neighbours screened as starts)",
               "starts": COUNT, "iterations": COUNT, "cells": COUNT, "resumed_cells": COUNT,
               "repair": "- (the round of repairs that gave the cell's optimum; 0: its first "
                         "solve)",
               "repairs": "- (count of cells solved again from a stricter neighbour's optimum)",
               "n_cells": COUNT, "n_feasible": COUNT,
               "bound": "the unit named by the entry's own unit key (reachable: the bound out "
                        "of reach)",
               "value": "the unit named by the entry's own unit key (reachable: the nearest "
                        "value any design in the bounds reaches)",
               "phases": COUNT, "count": COUNT, "finished_s": "s (since the run started)"}


def units(result) -> dict:
    """``{key: unit}`` of the atlas's keys that name a relative length."""
    spec = result.spec
    relative = RELATIVE.format(reg=spec.regulated)
    return ATLAS_UNITS | {k: relative for k in spec.lengths} | {
        "pin_radius": relative, "min_pin_radius": relative}


def columns(result) -> list[str]:
    spec = result.spec
    return (list(spec.axes) + ["status", "delta", "ratio", "transmission_angle_deg"] +
            [k for k in spec.lengths] + ["pin_radius", "binding", "message", "time_s",
                                         "neighbours", "repair"])


def rows(result) -> list[dict]:
    """One row a cell: the axes' values, the verdict, the figures, the relative lengths."""
    out = []
    for rec in result.records:
        row = dict(rec["values"]) | {k: rec.get(k) for k in (
            "status", "delta", "ratio", "pin_radius", "binding", "message", "time_s",
            "neighbours", "repair")}
        row["transmission_angle_deg"] = rec.get("min_transmission_angle_deg")
        row |= {k: rec["design"].get(k) for k in result.spec.lengths}
        out.append(row)
    return out


def to_frame(result):
    """The atlas as a pandas DataFrame, one row a cell (``frame.attrs['units']``)."""
    import pandas as pd
    frame = pd.DataFrame(rows(result), columns=columns(result))
    frame.attrs["units"] = units(result)
    return frame


def document(result) -> dict:
    """``atlas.json``: the atlas, its axes, its fixed values, every cell, with units."""
    spec = result.spec
    cells = [{k: v for k, v in rec.items() if k not in ("key", "kind", "epsilon")}
             for rec in result.records]
    doc = {"atlas": spec.name, "mechanism": spec.mechanism, "source": spec.source,
           "relative_to": spec.regulated,
           "axes": {k: list(v) for k, v in spec.axes.items()}, "fixed": dict(spec.fixed),
           "objective": "least ripple (delta)", "n_cells": len(cells),
           "n_feasible": result.n_feasible, "run": dict(result.run), "cells": cells}
    return stamped(doc, units(result))


def write_table(result, out) -> list[Path]:
    """atlas.csv and atlas.json in ``out``, each atomically."""
    out = Path(out)
    csv = to_frame(result).to_csv(index=False, float_format="%.10g")
    return [atomic_write_text(out / "atlas.csv", csv),
            atomic_write_json(out / "atlas.json", document(result))]

"""The front's own files, written atomically: the sweep writes them after every round, so an
interrupted sweep leaves the front it had (the figures and the report are the command's)."""
from __future__ import annotations

from pathlib import Path

from optdesign.outputs.atomic import atomic_write_bytes, atomic_write_json


def write_front(result, out_dir: str | Path) -> list[Path]:
    """pareto.csv and pareto.json."""
    out = Path(out_dir)
    csv = result.points.drop(columns=["index"]).to_csv(index=False, float_format="%.10g")
    return [atomic_write_bytes(out / "pareto.csv", csv.encode("utf-8")),
            atomic_write_json(out / "pareto.json", result.to_dict())]

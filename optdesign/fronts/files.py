"""The front's own files, written atomically: the sweep writes them after every round, so an
interrupted sweep leaves the front it had (the figures and the report are the command's)."""
from __future__ import annotations

from pathlib import Path

from optdesign.outputs.atomic import atomic_write_bytes, atomic_write_json


def write_front(result, out_dir: str | Path) -> list[Path]:
    """pareto.csv and pareto.json (:func:`front_files`)."""
    csv_path, json_path = front_files(out_dir)
    csv = result.points.drop(columns=["index"]).to_csv(index=False, float_format="%.10g")
    return [atomic_write_bytes(csv_path, csv.encode("utf-8")),
            atomic_write_json(json_path, result.to_dict())]


def front_files(out_dir: str | Path) -> list[Path]:
    """Where :func:`write_front` writes: pareto.csv and pareto.json in ``out_dir``."""
    out = Path(out_dir)
    return [out / "pareto.csv", out / "pareto.json"]

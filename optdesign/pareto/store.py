"""The sweep's journal: ``points.jsonl``, one JSON object a line, appended and fsynced as each
point finishes, so a killed run loses nothing that was written and ``--resume`` can continue.

A line is a *record*: ``{"key": [phases, tag], ...}``, tag ``"least_ripple"`` or
``"largest_ratio"`` for the two end-point solves of a phase count and the integer grid index
for the ε points. The first line holds the run's settings (``{"key": "run", ...}``) and resume
refuses a journal written for other settings.
"""
from __future__ import annotations

import json
import os
from pathlib import Path

from ..errors import ProblemError
from ..io import _jsonable, atomic_write_text


class Journal:
    """Append-only record of finished points."""

    def __init__(self, path: str | Path):
        self.path = Path(path)

    def read(self) -> tuple[dict | None, list[dict]]:
        """(run settings, records); a last line cut short by a kill is dropped."""
        if not self.path.exists():
            return None, []
        header, records = None, []
        for line in self.path.read_text(encoding="utf-8").splitlines():
            try:
                rec = json.loads(line)
            except json.JSONDecodeError:
                continue
            if rec.get("key") == "run":
                header = rec
            else:
                records.append(rec)
        return header, records

    def start(self, settings: dict, resume: bool) -> list[dict]:
        """Open the journal for a run; returns the records a resumed run keeps."""
        header, records = self.read()
        if resume and header is not None:
            old = {k: v for k, v in header.items() if k != "key"}
            if old != json.loads(json.dumps(settings, default=_jsonable)):
                changed = sorted(k for k in set(old) | set(settings)
                                 if old.get(k) != settings.get(k))
                raise ProblemError(f"{self.path}: cannot resume, the run's settings changed "
                                   f"({', '.join(changed)}); run without --resume to start "
                                   f"afresh")
            # drop a line a kill cut short, so the next append starts on a line of its own
            lines = [json.dumps(r, default=_jsonable) for r in [header, *records]]
            atomic_write_text(self.path, "\n".join(lines) + "\n")
            return records
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.path.write_text("", encoding="utf-8")
        self.append({"key": "run"} | settings)
        return []

    def append(self, record: dict) -> None:
        line = json.dumps(record, default=_jsonable) + "\n"
        fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
        try:
            os.write(fd, line.encode("utf-8"))      # one write per line: whole or nothing
            os.fsync(fd)
        finally:
            os.close(fd)

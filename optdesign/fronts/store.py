"""The sweep's journal: ``points.jsonl``, one JSON object a line, appended and fsynced as each
point finishes, so a killed run loses nothing that was written and ``--resume`` can continue.

A line is a *record*: ``{"key": [count, tag], ...}``, tag ``"least_ripple"`` or
``"largest_ratio"`` for the two end-point solves of a phase count and the integer grid index
for the ε points. The first line holds the run's settings (``{"key": "run", ...}``) and resume
refuses a journal written for other settings, and a damaged one (no settings line, a line in
the middle that is not a record): it names the file and never rewrites it. Only a last line
without its newline, cut short by a kill, is dropped.
"""
from __future__ import annotations

import errno
import json
import os
import stat
from pathlib import Path

from optdesign.errors import ProblemError
from optdesign.outputs.atomic import atomic_write_text, json_text


class Journal:
    """Append-only record of finished points."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        #: a resumed record's line in the file, by its key (for messages)
        self.line_of: dict = {}

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

    def read_to_resume(self) -> tuple[dict, list[dict], bool]:
        """(run settings, records, whole): the journal checked line by line; ``whole`` is
        False when its last line was cut short by a kill (then dropped).

        Raises
        ------
        ProblemError
            The journal is damaged: unreadable, no settings line first, or a line other than
            the last that is not a record.
        """
        def damaged(what):
            return ProblemError(f"{self.path}: damaged journal ({what}); it is left as it "
                                f"is: run without --resume to start afresh")

        self._require_regular()
        try:
            text = self.path.read_text(encoding="utf-8")
        except UnicodeDecodeError:
            raise damaged("not UTF-8 text") from None
        lines = text.split("\n")
        whole = lines[-1] == ""
        lines = lines[:-1] if whole else lines
        parsed = []
        for number, line in enumerate(lines, 1):
            rec = _record(line)
            if rec is None:
                if number == len(lines) and not whole:
                    break                                # cut short by a kill: dropped
                raise damaged(f"line {number} is not a record")
            if (rec["key"] == "run") != (number == 1):
                raise damaged("the first line is not the run's settings" if number == 1
                              else f"line {number} repeats the run's settings")
            if rec["key"] != "run":
                wrong = _missing(rec)
                if wrong:
                    raise damaged(f"line {number}: {wrong}")
                self.line_of[tuple(rec["key"])] = number
            parsed.append(rec)
        if not parsed:
            raise damaged("no settings line")
        return parsed[0], parsed[1:], whole

    def start(self, settings: dict, resume: bool) -> list[dict]:
        """Open the journal for a run; returns the records a resumed run keeps."""
        if resume and os.path.lexists(self.path):
            header, records, whole = self.read_to_resume()
            old = {k: v for k, v in header.items() if k != "key"}
            if old != json.loads(_line(settings)):
                changed = sorted(k for k in set(old) | set(settings)
                                 if old.get(k) != settings.get(k))
                raise ProblemError(f"{self.path}: cannot resume, the run's settings changed "
                                   f"({', '.join(changed)}); run without --resume to start "
                                   f"afresh")
            if not whole:
                # drop the line a kill cut short, so the next append starts a line of its own
                lines = [_line(r) for r in [header, *records]]
                atomic_write_text(self.path, "\n".join(lines) + "\n")
            return records
        # a fresh journal: the settings line alone, in place of any old one at once
        atomic_write_text(self.path, _line({"key": "run"} | settings) + "\n")
        return []

    def append(self, record: dict) -> None:
        line = _line(record) + "\n"
        try:
            fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_NOFOLLOW
                         | os.O_NONBLOCK | os.O_CLOEXEC, 0o644)
        except OSError as exc:
            if exc.errno == errno.ELOOP:
                raise ProblemError(f"{self.path}: has become a link; the journal is written "
                                   f"only as a regular file in the output folder") from None
            raise
        try:
            st = os.fstat(fd)
            if not stat.S_ISREG(st.st_mode):
                raise ProblemError(f"{self.path}: is not a regular file; the journal is "
                                   f"written only as a regular file in the output folder")
            if st.st_nlink > 1:
                raise ProblemError(f"{self.path}: has another name (a hard link); the "
                                   f"journal is written only as a file of the output folder's "
                                   f"own")
            os.write(fd, line.encode("utf-8"))      # one write per line: whole or nothing
            os.fsync(fd)
        finally:
            os.close(fd)

    def _require_regular(self) -> None:
        """Refuse a journal that is a link, a hard link (a file with another name, maybe
        outside the output folder, that an append would change) or anything but a regular
        file: what the run reads and appends to stays inside the output folder."""
        try:
            st = os.lstat(self.path)
        except FileNotFoundError:
            return
        if not stat.S_ISREG(st.st_mode) or st.st_nlink > 1:
            what = ("a link" if stat.S_ISLNK(st.st_mode) else "not a regular file"
                    if not stat.S_ISREG(st.st_mode) else
                    f"a file with {st.st_nlink} names (a hard link)")
            raise ProblemError(f"{self.path}: is {what}; a journal to resume must be a "
                               f"regular file of the output folder's own (it is left as it "
                               f"is)")


#: the statuses a record of a solve may hold: ``optimal`` (a verified feasible design, the one
#: status with ``feasible`` true), ``infeasible``, ``failed``
STATUSES = ("optimal", "infeasible", "failed")


def to_solve_again(records: dict) -> list:
    """The keys of the resumed ``records`` (by key) to solve again rather than keep, removed
    from ``records``: every one but a feasible ``optimal`` record. A feasible design can be
    checked (evaluated exactly again, by the caller); a verdict that no design was found
    cannot be checked without the solve, and a status that is not one of :data:`STATUSES`,
    or that disagrees with ``feasible`` (``"feasible": false, "status": "optimal"``), is no
    verdict at all. Solving them again keeps a forged or foreign record out of a front or an
    atlas, and gives the result an uninterrupted run gives."""
    keys = [k for k, r in records.items()
            if not (r["feasible"] is True and r["status"] == "optimal")]
    for k in keys:
        del records[k]
    return keys


#: a record's fields and their types (None allowed where a point has no verified design)
FIELDS = {"count": (int,), "kind": (str,), "status": (str,), "feasible": (bool,),
          "design": (dict,), "delta": (int, float, type(None)),
          "ratio": (int, float, type(None)), "epsilon": (int, float, type(None))}


def _missing(rec: dict) -> str:
    """What is wrong with a record's fields ('' when nothing): one missing or of the wrong
    type, a key whose count is not the record's, a feasible record without its figures."""
    if "count" not in rec and "phases" in rec:      # a journal written before "count"
        rec["count"] = rec["phases"]
    for name, types in FIELDS.items():
        if name not in rec:
            return f"the record has no {name}"
        value = rec[name]
        if not isinstance(value, types) or (isinstance(value, bool) and bool not in types):
            return f"the record's {name} is not a {types[0].__name__}"
    if rec["key"][0] != rec["count"]:
        return f"the record's key names count {rec['key'][0]}, its count {rec['count']}"
    if rec["feasible"] and (rec["delta"] is None or rec["ratio"] is None or not rec["design"]):
        return "a feasible record without its design, delta or ratio"
    return ""


def _record(line: str) -> dict | None:
    """The record a journal line holds, or None when it holds none (not JSON, not an object,
    no key, a key that is neither ``"run"`` nor ``[count, tag]``)."""
    try:
        rec = json.loads(line)
    except json.JSONDecodeError:
        return None
    if not isinstance(rec, dict):
        return None
    key = rec.get("key")
    if key == "run" or (isinstance(key, list) and len(key) == 2 and isinstance(key[0], int)
                        and isinstance(key[1], (int, str))):
        return rec
    return None


def _line(record: dict) -> str:
    """One journal line: strict JSON (a NaN is null), no ``non_finite`` key (a record is a
    table row when read back)."""
    return json_text(record, indent=None, reasons=False)

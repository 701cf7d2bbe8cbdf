"""Which problem file an output folder's results came from: a run never replaces another
file's results without being told to.

The first run into a folder records its problem file there, ``.optdesign-source.json``
(``{"problem": "/the/resolved/path.yaml"}``); a later run of another file into a folder that
holds results (any file but hidden ones) is refused before any work, one line naming both
files, unless ``--force``. A run of the same file (by its resolved path, however it was
edited since) goes on. A folder without the record (results of an older release, or files of
the user's) is claimed by the first run that writes there, as before.
"""
from __future__ import annotations

import json
import os
from pathlib import Path

from optdesign.errors import UsageError, shown

#: the record, in the folder beside the results (part of every command's set)
SOURCE = ".optdesign-source.json"


def resolved(problem_file) -> str:
    """The problem file's path as the record holds it: absolute, links resolved."""
    return os.path.realpath(os.fspath(problem_file))


def recorded(folder: Path) -> str | None:
    """The problem file the folder's record names, or None (no record, or not one of ours)."""
    path = Path(folder) / SOURCE
    try:
        if path.is_symlink() or not path.is_file() or path.stat().st_size > 1 << 14:
            return None
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    problem = data.get("problem") if isinstance(data, dict) else None
    return problem if isinstance(problem, str) else None


def results_in(folder: Path) -> list[str]:
    """The names of the results a folder holds (every file but hidden ones), sorted."""
    try:
        return sorted(e.name for e in Path(folder).iterdir()
                      if not e.name.startswith(".") and e.is_file())
    except OSError:
        return []


def claim(folder: Path, label: str, problem_file, force: bool = False,
          write: bool = True) -> None:
    """Refuse (:class:`UsageError`, exit 2) a run of ``problem_file`` into ``folder`` (as
    ``label`` names it) whose results came from another problem file, unless ``force``;
    then, with ``write``, record ``problem_file`` as the folder's (a run that writes its set
    whole records it in the set instead, :class:`optdesign.outputs.folder.OutputFolder`)."""
    mine = resolved(problem_file)
    theirs = recorded(folder)
    held = results_in(folder)
    if theirs is not None and theirs != mine and held and not force:
        raise UsageError(f"{label}: holds the results of {shown(theirs)} ({', '.join(held[:3])}"
                         f"{', ...' if len(held) > 3 else ''}), not of "
                         f"{shown(os.fspath(problem_file))}; give another --out, or --force "
                         f"to replace them")
    if write and theirs != mine:
        record(folder, problem_file)


def record(folder: Path, problem_file) -> None:
    """Record ``problem_file`` as the source of the results in ``folder``."""
    from optdesign.outputs.atomic import atomic_write_json

    atomic_write_json(Path(folder) / SOURCE, {"problem": resolved(problem_file)})

"""Output folders, checked before any work: a command that would write nowhere says so at
once (exit 2), not after a solve of many minutes.

A problem's ``name`` becomes a folder's name, never a path: ``../../x``, ``/etc`` or a name of
300 characters all end up as one safe folder under ``results/``.
"""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

from optdesign.errors import UsageError, shown
from optdesign.outputs.links import followed

#: where the commands write when no ``--out`` is given
RESULTS = Path("results")
#: longest folder name made from a problem name, in UTF-8 bytes (file systems allow 255)
MAX_FOLDER_BYTES = 120
#: kernel file systems: never a place for results (but /dev/shm, a RAM disk, is one)
SYSTEM_TREES = ("/proc", "/sys", "/dev")
RAM_DISK = "/dev/shm"


def safe_folder_name(name: str) -> str:
    """``name`` as one folder name: letters, digits and ``-_.+`` kept, anything else (a
    slash, a space, a control character) an underscore, no leading dot, at most
    MAX_FOLDER_BYTES bytes; "problem" when nothing is left."""
    text = "".join(c if (c.isalnum() or c in "-_.+") and c.isprintable() else "_"
                   for c in name)
    text = text.lstrip("._")
    while len(text.encode("utf-8", "replace")) > MAX_FOLDER_BYTES:
        text = text[:-1]
    return text.rstrip(".") or "problem"


def default_out(name: str, suffix: str = "") -> Path:
    """``results/NAME{suffix}`` with the name made safe (the suffix, such as ``_pareto``,
    kept whole however long the name)."""
    return RESULTS / (safe_folder_name(name) + suffix)


def system_tree(real: str) -> str | None:
    """The kernel file system (``/proc``, ``/sys``, ``/dev`` but its RAM disk) that the
    resolved path ``real`` lies in, or None."""
    for tree in SYSTEM_TREES:
        if (real == tree or real.startswith(tree + os.sep)) and \
                not real.startswith(RAM_DISK + os.sep):
            return tree
    return None


def resolve_out(out: str | Path | None, name: str, suffix: str = "",
                option: str = "--out") -> tuple[Path, str]:
    """(the output folder, its label for messages), checked and normalised but not created.

    ``out`` is the ``--out`` argument (None: :func:`default_out` of ``name``). An empty name
    is refused (it would mean the current folder); ``..`` is resolved as the kernel resolves
    it, so ``a/b/../../x`` is ``x`` and creates no ``a/b``. A link on the way that the
    kernel's protected-symlinks rule would not follow (another user's, in a shared sticky
    folder: :mod:`optdesign.outputs.links`) is refused. Raises :class:`UsageError`.
    """
    label = f"{option} {shown(str(out))}" if out is not None else \
        f"{default_out(name, suffix)} (the default output folder; give {option})"
    text = os.fspath(out) if out is not None else str(default_out(name, suffix))
    if not text.strip() or "\0" in text:
        raise UsageError(f"{label}: is not a folder name")
    path = Path(text)
    real = followed(path, label)
    tree = system_tree(real)
    if tree:
        raise UsageError(f"{label}: is under {tree}, not a place for results")
    if ".." in path.parts:
        path = Path(real) if path.is_absolute() else Path(os.path.relpath(real))
    return path, label


def prepare_out(out: str | Path | None, name: str, suffix: str = "",
                files: tuple[str, ...] = (), option: str = "--out", source=None,
                force: bool = False, record: bool = True) -> Path:
    """The output folder of a command (:func:`resolve_out`), made and checked writable
    before any work.

    ``files`` are the names the command will write there: none may be a folder. With
    ``source`` (the problem file), a folder holding the results of another problem file is
    refused unless ``force``, and (with ``record``: a command that writes in place) the folder
    is recorded as ``source``'s (:mod:`optdesign.outputs.provenance`; a command that writes
    its set whole records it in the set). Raises :class:`UsageError` (exit 2) naming the
    folder (as ``option``, the flag or the API's argument, gave it) and the reason.
    """
    path, label = resolve_out(out, name, suffix, option)
    try:
        if path.exists() and not path.is_dir():
            raise UsageError(f"{label}: exists and is not a folder")
        path.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(dir=path, prefix=".optdesign-probe-")
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise UsageError(f"{label}: cannot write there "
                         f"({exc.strerror or type(exc).__name__})") from None
    for name_ in files:
        if (path / name_).is_dir():
            raise UsageError(f"{label}: {name_} there is a folder; the command writes a file "
                             f"of that name")
    if source is not None:
        from optdesign.outputs.provenance import claim

        claim(path, label, source, force, record)
    return path

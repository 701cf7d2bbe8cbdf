"""What the code and the constants of a process's CasADi graphs come from, besides their own
arguments: one stamp, named by records kept on disk that let a later process skip a graph
(an NLP's, :mod:`optdesign.solver.nlp_memo`; a mechanism's lanes,
:mod:`optdesign.numerics.lanes_index`). The standard library only at import (the warm
server's client stamps the package's files with it before anything else is loaded)."""
from __future__ import annotations

import hashlib
import os
import platform
import sys
from functools import lru_cache
from pathlib import Path

#: the package's folder, whose files' stamps name every record (:func:`package_stamp`)
PACKAGE = Path(__file__).resolve().parents[1]


@lru_cache(maxsize=1)
def environment() -> tuple:
    """The package's files (path, modification time, size: :func:`package_stamp`), the
    interpreter's, NumPy's and CasADi's versions, the machine, the C library and the CPU
    features NumPy dispatches on (a cache folder shared by two machines whose sine differs
    in the last bit names two records)."""
    import casadi as ca
    import numpy as np
    try:
        from numpy._core._multiarray_umath import __cpu_features__ as features
    except ImportError:                     # (NumPy before 2)
        from numpy.core._multiarray_umath import __cpu_features__ as features
    try:
        libc = os.confstr("CS_GNU_LIBC_VERSION") or ""
    except (ValueError, OSError):
        libc = ""
    return (package_stamp(PACKAGE), str(PACKAGE), sys.version, np.__version__, ca.__version__,
            platform.machine(), libc, sorted(k for k, on in features.items() if on))


def package_stamp(folder: Path | None = None) -> str:
    """A sha256 digest of the relative path, modification time and size of every file under
    ``folder`` (the package's by default), its bytecode folders aside: what names the code a
    server runs (:func:`optdesign.warm.place.fingerprint`) and what a record of a graph was
    made by (:func:`environment`). A file changed in place, added or removed changes it."""
    folder = PACKAGE if folder is None else folder
    files = hashlib.sha256()
    folders = [""]
    while folders:
        sub = folders.pop()
        try:
            entries = sorted(os.scandir(folder / sub), key=lambda e: e.name)
        except OSError:
            continue
        for entry in entries:
            name = f"{sub}/{entry.name}" if sub else entry.name
            try:
                if entry.is_dir(follow_symlinks=False):
                    if entry.name != "__pycache__":
                        folders.append(name)
                    continue
                st = entry.stat()
            except OSError:
                continue
            files.update(f"{name}\0{st.st_mtime_ns}\0{st.st_size}\n".encode(
                "utf-8", "surrogateescape"))
    return files.hexdigest()

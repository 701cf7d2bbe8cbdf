"""Where the warm server listens, and which server a command may use.

The socket lives in a folder only this user can enter: ``$OPTDESIGN_SERVER_DIR`` if set, else
``$XDG_RUNTIME_DIR/optdesign``, else ``$TMPDIR/optdesign-UID`` (``/tmp`` without TMPDIR). The
folder is created with mode 0700 and used only when it is a real folder (not a link), owned by
this user and closed to everyone else; otherwise there is no server and every command runs in
its own process. One server serves one installation: the socket's name is a checksum of the
package's folder, the interpreter and the version of the messages.

A command hands its work to the server only when the server's **fingerprint** equals its own:
the interpreter, its version and options (``-X``, ``-W``), the encodings it fixed as it started
(file names' and ``open``'s default), the import path with each folder's modification time (an
installed or upgraded package changes its folder's), the modification time and size of every
file of the package, and the environment variables read as libraries are imported (BLAS
threads, matplotlib's, Python's own, ``OPTDESIGN_*``). Anything else a command reads (the rest
of the environment, the locale, the working folder, the umask, the resource limits, the signals
ignored) the child takes from the client (:mod:`optdesign.warm.child`). This module imports the
standard library only (and :mod:`optdesign.numerics.code_stamp`'s stamp of the files, which
does too): the client runs it before anything else.
"""
from __future__ import annotations

import json
import os
import stat
import sys
import zlib
from pathlib import Path

from optdesign.numerics.code_stamp import package_stamp

#: ``off`` (or 0, no, false) runs every command in its own process and starts no server
VARIABLE = "OPTDESIGN_SERVER"
#: the folder of the socket (default: see the module's text)
FOLDER_VARIABLE = "OPTDESIGN_SERVER_DIR"
#: seconds the server waits for a command before it ends
IDLE_VARIABLE = "OPTDESIGN_SERVER_IDLE"
IDLE_DEFAULT_S = 900.0
_ON, _OFF = {"", "on", "1", "yes", "true"}, {"off", "0", "no", "false"}

#: the optdesign package's folder
PACKAGE = Path(__file__).resolve().parents[1]
#: variables read while the libraries are imported (by prefix, and by name)
_IMPORT_PREFIXES = ("PYTHON", "MPL", "OMP_", "OPENBLAS", "MKL_", "GOTO", "BLIS", "VECLIB",
                    "NUMEXPR", "CASADI", "LD_", "DASK", "TQDM_", "EZDXF", "OPTDESIGN_")
_IMPORT_NAMES = ("HOME", "TZ", "TMPDIR", "XDG_CONFIG_HOME", "XDG_CACHE_HOME")
#: variables read when a command runs, not when it imports (this package's), or whose
#: effect the child takes on from the client (the encoding of its standard streams)
_RUN_ONLY = (VARIABLE, FOLDER_VARIABLE, IDLE_VARIABLE, "OPTDESIGN_PHASES", "PYTHONIOENCODING")
#: the version of the messages between client and server (:mod:`optdesign.warm.wire`), part
#: of the socket's name: a server of an older version is never reached, and ends when idle
PROTOCOL = 2
#: the longest path of a Unix socket (``sun_path`` holds 108 bytes with its final NUL)
_SOCKET_PATH_MAX = 107


class SettingError(ValueError):
    """An environment variable of the warm server with a value it does not take."""


def enabled(env=os.environ) -> bool:
    """False when ``OPTDESIGN_SERVER`` says off; :class:`SettingError` for a value it
    does not know."""
    value = env.get(VARIABLE, "").strip().lower()
    if value in _ON or value in _OFF:
        return value not in _OFF
    raise SettingError(f"environment variable {VARIABLE}: expected on or off, "
                       f"got {env[VARIABLE]!r}")


def idle_seconds(env=os.environ) -> float:
    """How long the server waits for a command (``OPTDESIGN_SERVER_IDLE``, > 0)."""
    text = env.get(IDLE_VARIABLE, "").strip()
    if not text:
        return IDLE_DEFAULT_S
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not 0 < value < 1e9:
        raise SettingError(f"environment variable {IDLE_VARIABLE}: expected a number of "
                           f"seconds > 0, got {env[IDLE_VARIABLE]!r}")
    return value


def folder(env=os.environ) -> Path:
    """The socket's folder (see the module's text); not created, not checked."""
    if env.get(FOLDER_VARIABLE):
        return Path(env[FOLDER_VARIABLE])
    if env.get("XDG_RUNTIME_DIR"):
        return Path(env["XDG_RUNTIME_DIR"]) / "optdesign"
    return Path(env.get("TMPDIR") or "/tmp") / f"optdesign-{os.getuid()}"


def private(path: Path, create: bool = False) -> bool:
    """True when ``path`` is a folder (not a link) of this user that nobody else may enter;
    with ``create``, a missing one is made so (its parent must exist)."""
    if create:
        try:
            os.mkdir(path, 0o700)
        except FileExistsError:
            pass
        except OSError:
            return False
    try:
        st = os.lstat(path)
    except OSError:
        return False
    return (stat.S_ISDIR(st.st_mode) and st.st_uid == os.getuid()
            and not st.st_mode & 0o077)


def socket_path(env=os.environ) -> Path | None:
    """The socket of this installation's server, or None where there can be none (no
    private folder; a path too long for a Unix socket)."""
    where = folder(env)
    key = f"{PACKAGE}\0{sys.executable}\0{PROTOCOL}".encode("utf-8", "surrogateescape")
    path = where / f"{zlib.crc32(key):08x}{zlib.adler32(key):08x}.sock"
    if len(os.fsencode(path)) > _SOCKET_PATH_MAX:
        return None
    return path


def fingerprint(env=os.environ) -> str:
    """What a server must share with a command to run it (see the module's text)."""
    paths = []
    for entry in sys.path[1:]:          # the first is the script's or working folder
        try:
            paths.append([entry, os.stat(entry or ".").st_mtime_ns])
        except OSError:
            paths.append([entry, None])
    names = {k: v for k, v in env.items()
             if (k.startswith(_IMPORT_PREFIXES) or k in _IMPORT_NAMES) and k not in _RUN_ONLY}
    # UTF-8 mode is no flag of its own here: the C locale turns it on in a command and not in
    # the server the command starts (the command hands on LC_CTYPE=C.UTF-8, coerced), so
    # the encodings it decides are compared instead
    flags = [value for name, value in zip(type(sys.flags).__match_args__, sys.flags)
             if name != "utf8_mode"]
    return json.dumps({"python": [sys.executable, sys.version, flags, sys.warnoptions,
                                  sys._xoptions], "encodings": text_encodings(),
                       "path": paths, "package": [str(PACKAGE), package_stamp(PACKAGE)],
                       "environment": names}, sort_keys=True)


def text_encodings() -> list[str]:
    """The encodings fixed as the interpreter starts, which a child cannot take on from its
    client: file names' (and their error handler), and the default of ``open``."""
    import codecs
    import locale

    return [codecs.lookup(sys.getfilesystemencoding()).name, sys.getfilesystemencodeerrors(),
            codecs.lookup(locale.getpreferredencoding(False)).name]


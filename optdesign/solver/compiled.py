"""The NLP's derivatives compiled to C, cached on disk: IPOPT off CasADi's virtual machine.

Most of an IPOPT run goes to the NLP's derivatives (the constraint Jacobian above all), which
CasADi evaluates on its virtual machine. Generated as C (``generate_dependencies``) and
compiled with ``gcc -O1`` they run about ten times faster, with the same operations in the
same order: the same iterates, the same answer to the last bit. Compiling takes 10 s to two
minutes per NLP, so it happens once, and never while a command waits:

* an NLP's library is named by a digest of the NLP's function (x, p) -> (f, g) as CasADi
  serialises it (its expression graph, from which the generated code follows), CasADi's
  version, the machine, the compiler's flags and the Hessian IPOPT asks for; it lives in the
  user's cache folder (:mod:`optdesign.numerics.user_cache`: ``$XDG_CACHE_HOME/optdesign``,
  else ``~/.cache/optdesign``, mode 0700);
* a solve that finds its library loads it (a millisecond or two) when the file is the user's
  own, not writable by group or others, and ends in a trailer with the NLP's digest and the
  checksum of the bytes before it: a corrupt, foreign or stale file is ignored (and built
  anew), never mapped;
* a solve that finds none runs on the virtual machine, as without a compiler, and starts the
  build beside it: a detached, niced process, one per digest (a lock file) and one at a time
  per cache folder (:data:`MAX_DETACHED_BUILDS`); the next solve of the same NLP loads the
  library. A build that fails leaves a note in the folder, read out
  under ``--debug``, and is tried again after :data:`RETRY_AFTER_S` or by ``optdesign
  warm-up``, which builds a problem's libraries ahead of time (:func:`warm_up`).

``OPTDESIGN_COMPILE``: ``on`` (the default), ``load`` (load libraries, start no build: the
test suite), ``off`` (the virtual machine always, nothing cached read or written). Without
``gcc`` on PATH nothing is built.
"""
from __future__ import annotations

import hashlib
import logging
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import casadi as ca

from optdesign.numerics.user_cache import (MODES, VARIABLE, folder, mode, trailer, trusted,
                                           write as _write)

__all__ = ["MODES", "VARIABLE", "Recipe", "build", "building", "builds_under_way", "compiler",
           "folder", "library", "mode", "name_of", "nlpsol", "recipe", "start", "warm_up"]

COMPILER = "gcc"
#: -O1: -O2 is no faster on these functions and compiles longer; no contraction into fused
#: multiply-adds, so the C code rounds as the virtual machine does on every target
FLAGS = ("-O1", "-shared", "-fPIC", "-ffp-contract=off")
#: the library's layout (its stamp function, its file names): part of the digest
FORMAT = 1
#: a library's trailer: this tag, the NLP's digest and the checksum of the bytes before it
TRAILER_TAG = "optdesign-nlp"
#: a lock this old belongs to a build that died: taken over
LOCK_STALE_S = 3600.0
#: a failed build is not started again by a solve for this long (warm-up always tries)
RETRY_AFTER_S = 86400.0
#: the niceness of a build started beside a solve
NICE = 10
#: builds started beside solves that run at once, per cache folder: a compiler takes 1-2.5 GB
#: and a core for minutes, and a run of many distinct problems (an oracle, a script over
#: files) would otherwise start one per problem; a solve that finds the slot taken starts
#: none, and a later solve of its NLP starts it
MAX_DETACHED_BUILDS = 1

log = logging.getLogger("optdesign.compiled")


def compiler() -> str | None:
    """The C compiler's path, or None where there is none on PATH."""
    return shutil.which(COMPILER)


@dataclass(frozen=True)
class Recipe:
    """What one library is built from: the NLP's function (x, p) -> (f, g) and its
    serialised text, the Hessian IPOPT asks for, and the digest of both with everything else
    the code depends on."""

    function: ca.Function
    serialized: str
    hessian: str
    digest: str

    @property
    def name(self) -> str:
        return name_of(self.digest)


def name_of(digest: str) -> str:
    """The files' common name of a digest (``.so``, ``.lock``, ``.failed``, ``.casadi``)."""
    return f"nlp-{digest[:40]}"


def recipe(x, p, f, g, hessian: str) -> Recipe:
    """The recipe of the NLP min f(x; p) s.t. g(x; p) for IPOPT with ``hessian``."""
    function = ca.Function("nlp", [x, p], [f, g], ["x", "p"], ["f", "g"])
    digest = hashlib.sha256()
    for part in (str(FORMAT), ca.__version__, platform.machine(), " ".join(FLAGS), hessian):
        digest.update(part.encode() + b"\0")
    serialized = function.serialize()
    digest.update(serialized.encode())
    return Recipe(function, serialized, hessian, digest.hexdigest())


def library(rec: Recipe, where: Path) -> Path | None:
    """The cached library of ``rec`` in ``where``, or None: missing, not a regular file of
    this user's, writable by group or others, cut short or changed since it was built (its
    trailer's checksum), or built for another NLP (its trailer's digest). Checked before it
    is loaded: a library cut short would crash the process that maps it."""
    path = where / f"{rec.name}.so"
    return path if trusted(path, TRAILER_TAG, rec.digest) is not None else None


def nlpsol(name: str, x, p, f, g, opts: dict) -> ca.Function:
    """IPOPT on min f(x; p) s.t. g(x; p) with ``opts``: on the compiled library where one is
    cached, else on the virtual machine, with a build started beside (``OPTDESIGN_COMPILE``
    on and a compiler on PATH)."""
    how = mode()
    if how != "off":
        hessian = opts.get("ipopt.hessian_approximation", "exact")
        try:
            rec = recipe(x, p, f, g, hessian)
            where = folder()
            path = library(rec, where) if where is not None else None
            if path is not None:
                log.debug("the NLP's derivatives compiled: %s", path)
                return ca.nlpsol(name, "ipopt", str(path), opts)
            if how == "on" and where is not None:
                start(rec, where)
        except (OSError, RuntimeError) as exc:     # a cache that fails costs the speed only
            log.debug("compiled derivatives not used (%s)", exc)
    return ca.nlpsol(name, "ipopt", {"x": x, "p": p, "f": f, "g": g}, opts)


def _lock(where: Path, name: str) -> bool:
    """Take the build lock of ``name`` (one build per digest); a lock whose build process
    has ended, or older than :data:`LOCK_STALE_S`, is taken over."""
    lock = where / f"{name}.lock"
    for _ in range(2):
        try:
            os.close(os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o600))
            return True
        except FileExistsError:
            if building(where, name):
                return False
            lock.unlink(missing_ok=True)
    return False


def building(where: Path, name: str) -> bool:
    """Whether a build of ``name`` is under way: its lock names a process that runs (or
    none yet, the build being started) and is younger than :data:`LOCK_STALE_S`."""
    lock = where / f"{name}.lock"
    try:
        if time.time() - os.lstat(lock).st_mtime >= LOCK_STALE_S:
            return False
        text = lock.read_text().strip()
    except OSError:
        return False
    if not text.isdigit():
        return True
    try:
        os.kill(int(text), 0)
    except ProcessLookupError:
        return False
    except OSError:                 # a process of another user's: it runs
        pass
    return True


def builds_under_way(where: Path) -> int:
    """How many builds run in ``where`` (:func:`building`, by their lock files)."""
    try:
        names = [lock.name[:-len(".lock")] for lock in where.glob("*.lock")]
    except OSError:
        return 0
    return sum(building(where, name) for name in names)


def _failed_recently(where: Path, name: str) -> str | None:
    """The note of a build of ``name`` that failed less than :data:`RETRY_AFTER_S` ago."""
    note = where / f"{name}.failed"
    try:
        if time.time() - os.lstat(note).st_mtime < RETRY_AFTER_S:
            return note.read_text(errors="replace").strip().splitlines()[0][:300]
    except (OSError, IndexError):
        pass
    return None


def start(rec: Recipe, where: Path, detached: bool = True,
          retry: bool = False) -> subprocess.Popen | None:
    """Start building ``rec``'s library in a process of its own (``detached``: niced, in a
    session of its own, waited for by nobody); None where no build starts (no compiler, one
    under way, one failed recently unless ``retry``)."""
    gcc = compiler()
    if gcc is None:
        log.debug("no C compiler (%s) on PATH: the NLP runs on CasADi's virtual machine",
                  COMPILER)
        return None
    failed = None if retry else _failed_recently(where, rec.name)
    if failed is not None:
        log.debug("an earlier build of %s failed (%s); `optdesign warm-up` tries again",
                  where / f"{rec.name}.so", failed)
        return None
    if detached and builds_under_way(where) >= MAX_DETACHED_BUILDS:
        log.debug("a build is under way in %s: %s is built by a later solve or `optdesign "
                  "warm-up`", where, where / f"{rec.name}.so")
        return None
    if not _lock(where, rec.name):
        return None
    lock, source = where / f"{rec.name}.lock", None
    try:
        source = _write(where / f"{rec.name}.casadi", rec.serialized.encode(), keep=True)
        package = str(Path(__file__).resolve().parents[2])
        env = dict(os.environ, PYTHONPATH=os.pathsep.join(
            [package] + [x for x in os.environ.get("PYTHONPATH", "").split(os.pathsep) if x]))
        command = [sys.executable, "-m", "optdesign.solver.compiled", str(where), rec.digest,
                   rec.hessian, gcc, source.name] + (["--detached"] if detached else [])
        child = subprocess.Popen(command, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                 stderr=subprocess.DEVNULL if detached else subprocess.PIPE,
                                 start_new_session=detached, cwd=where, env=env)
        lock.write_text(str(child.pid))         # the build's own process holds the lock
    except OSError as exc:
        lock.unlink(missing_ok=True)
        if source is not None:
            source.unlink(missing_ok=True)
        log.debug("the build of %s did not start (%s)", where / f"{rec.name}.so", exc)
        return None
    log.debug("compiling the NLP's derivatives beside the solve into %s",
              where / f"{rec.name}.so")
    return child


def build(where: Path, digest: str, hessian: str, gcc: str, source: str) -> Path:
    """Generate the C code of the NLP serialised in ``where``/``source`` for ``digest``,
    compile it and put the library in place (atomically); the lock and the serialised NLP
    are removed, a failure is noted in ``NAME.failed`` and raised."""
    name = name_of(digest)
    work = Path(tempfile.mkdtemp(prefix=f".{name}.", dir=where))
    try:
        function = ca.Function.deserialize((where / source).read_text())
        solver = ca.nlpsol("nlp", "ipopt", function, {"ipopt.hessian_approximation": hessian})
        os.chdir(work)                   # generate_dependencies writes into the working folder
        code = Path(solver.generate_dependencies("nlp_deps.c"))
        done = subprocess.run([gcc, *FLAGS, code.name, "-o", "nlp.so", "-lm"],
                              capture_output=True, text=True)
        if done.returncode != 0:
            raise RuntimeError(f"{gcc} exited with {done.returncode}: "
                               f"{' '.join(done.stderr.split())[-500:]}")
        body = (work / "nlp.so").read_bytes()
        with open(work / "nlp.so", "ab") as fh:
            fh.write(trailer(TRAILER_TAG, digest, body))
        os.chmod(work / "nlp.so", 0o700)
        os.replace(work / "nlp.so", where / f"{name}.so")
        (where / f"{name}.failed").unlink(missing_ok=True)
        return where / f"{name}.so"
    except Exception as exc:
        _write(where / f"{name}.failed", f"{type(exc).__name__}: {exc}\n".encode())
        raise
    finally:
        os.chdir(where)
        shutil.rmtree(work, ignore_errors=True)
        (where / source).unlink(missing_ok=True)
        (where / f"{name}.lock").unlink(missing_ok=True)


def warm_up(recipes: list[Recipe], where: Path, processes: int = 1) -> list[tuple]:
    """Build the libraries of ``recipes`` now, ``processes`` at a time (each build a process
    of its own): (recipe, library path or None, seconds, note) each, in order. A library
    already cached is not built again; a build under way (started beside a solve) is waited
    for."""
    out: dict[int, tuple] = {}
    pending = list(enumerate(recipes))
    running: list[tuple] = []
    t0 = time.perf_counter()
    while pending or running:
        for i, rec in list(pending):
            if len(running) >= max(processes, 1):
                break
            path = library(rec, where)
            if path is not None or compiler() is None:
                pending.remove((i, rec))
                out[i] = (rec, path, time.perf_counter() - t0,
                          "cached" if path is not None else "no C compiler")
                continue
            child = start(rec, where, detached=False, retry=True)
            if child is None and building(where, rec.name):
                continue                        # another's build of it: wait for that
            pending.remove((i, rec))
            if child is None:
                out[i] = (rec, None, 0.0, "not started")
            else:
                running.append((i, rec, child, time.perf_counter()))
        if running:
            i, rec, child, started = running.pop(0)
            _, err = child.communicate()
            path = library(rec, where)
            note = "compiled" if path is not None else \
                (err.decode(errors="replace").strip().splitlines() or ["failed"])[-1]
            out[i] = (rec, path, time.perf_counter() - started, note)
        elif pending:
            time.sleep(0.5)
    return [out[i] for i in range(len(recipes))]


def _main(argv: list[str]) -> int:
    """The build process: ``WHERE DIGEST HESSIAN GCC SOURCE [--detached]``."""
    where, digest, hessian, gcc, source = Path(argv[0]), *argv[1:5]
    if "--detached" in argv[5:]:
        try:
            os.nice(NICE)
        except OSError:
            pass
    try:
        build(where, digest, hessian, gcc, source)
    except Exception as exc:
        print(f"{type(exc).__name__}: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(_main(sys.argv[1:]))

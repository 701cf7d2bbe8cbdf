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
  checksum of the bytes before it (read once per version of the file,
  :func:`optdesign.numerics.user_cache.intact`): a corrupt, foreign or stale file is ignored
  (and built anew), never mapped;
* a solve that finds none runs on the virtual machine, as without a compiler, and starts the
  build beside it: a detached, niced process, one per digest (a lock file) and one NLP at a
  time per cache folder; the next solve of the same NLP loads the library. A build that fails
  leaves a note in the folder, read out under ``--debug``, and is tried again a day later or
  by ``optdesign warm-up``, which builds a problem's libraries ahead of time (:func:`warm_up`).

The building, the locks and the trust are :mod:`optdesign.numerics.c_library`'s (the NumPy
lanes' compiled loop is built the same way); this module makes an NLP's recipe and loads it.

``OPTDESIGN_COMPILE``: ``on`` (the default), ``load`` (load libraries, start no build: the
test suite), ``off`` (the virtual machine always, nothing cached read or written). Without
``gcc`` on PATH nothing is built.
"""
from __future__ import annotations

import hashlib
import platform
from pathlib import Path

import casadi as ca

from optdesign.numerics.c_library import (COMPILER, FLAGS, Recipe, build, building,
                                          builds_under_way, compiler, library, library_named,
                                          log, name_of, start, warm_up)
from optdesign.numerics.user_cache import MODES, VARIABLE, folder, mode

# the NLP's side of the C libraries, and the names callers of this module have always used
__all__ = ["COMPILER", "MODES", "VARIABLE", "Recipe", "build", "building", "builds_under_way",
           "compiler", "folder", "library", "library_of", "mode", "name_of", "nlpsol",
           "nlpsol_of", "recipe", "start", "warm_up"]

#: the library's layout (its stamp function, its file names): part of the digest
FORMAT = 1


def recipe(x, p, f, g, hessian: str) -> Recipe:
    """The recipe of the NLP min f(x; p) s.t. g(x; p) for IPOPT with ``hessian``."""
    function = ca.Function("nlp", [x, p], [f, g], ["x", "p"], ["f", "g"])
    digest = hashlib.sha256()
    for part in (str(FORMAT), ca.__version__, platform.machine(), " ".join(FLAGS), hessian):
        digest.update(part.encode() + b"\0")
    serialized = function.serialize()
    digest.update(serialized.encode())
    return Recipe(function, serialized, hessian, digest.hexdigest())


def nlpsol(name: str, x, p, f, g, opts: dict, found: dict | None = None) -> ca.Function:
    """IPOPT on min f(x; p) s.t. g(x; p) with ``opts``: on the compiled library where one is
    cached (its digest then put in ``found``, when given, as ``found["digest"]``), else on
    the virtual machine, with a build started beside (``OPTDESIGN_COMPILE`` on and a
    compiler on PATH)."""
    how = mode()
    if how != "off":
        hessian = opts.get("ipopt.hessian_approximation", "exact")
        try:
            rec = recipe(x, p, f, g, hessian)
            where = folder()
            path = library(rec, where) if where is not None else None
            if path is not None:
                if found is not None:
                    found["digest"] = rec.digest
                return nlpsol_of(name, path, opts)
            if how == "on" and where is not None:
                start(rec, where)
        except (OSError, RuntimeError) as exc:     # a cache that fails costs the speed only
            log.debug("compiled derivatives not used (%s)", exc)
    return ca.nlpsol(name, "ipopt", {"x": x, "p": p, "f": f, "g": g}, opts)


def library_of(digest: str) -> Path | None:
    """The cached library of the NLP whose recipe has ``digest`` (:func:`recipe`), where it
    is intact and the user's own (:func:`library`'s terms), else None."""
    where = folder() if mode() != "off" else None
    return library_named(where, digest) if where is not None else None


def nlpsol_of(name: str, path: Path, opts: dict) -> ca.Function:
    """IPOPT with ``opts`` on the NLP compiled into the library ``path``
    (:func:`library_of`)."""
    log.debug("the NLP's derivatives compiled: %s", path)
    return ca.nlpsol(name, "ipopt", str(path), opts)

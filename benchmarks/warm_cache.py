"""Helpers of the benchmarks that time whole commands on compiled derivatives.

A command builds NLPs a problem file does not foretell (a sweep's exact-Hessian rescues, a
cell's own count): :func:`warm_up` runs it until every NLP it builds loads a library from the
user's cache.
"""
from __future__ import annotations

import os
import subprocess
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
WARM_UP_ROUNDS = 8


def env_of(mode: str, code: Path | None = None) -> dict:
    """The environment of a run; ``code``: a folder whose ``optdesign`` package runs instead
    of this tree's."""
    env = dict(os.environ, OPTDESIGN_COMPILE=mode, OPTDESIGN_SERVER="off")
    if code is not None:
        env["PYTHONPATH"] = str(code)
    return env


def exported(rev: str, folder: Path) -> Path:
    """The package as it was at ``rev``, written out of this repository's history."""
    target = folder / f"code-{rev}"
    target.mkdir()
    archive = subprocess.run(["git", "archive", rev, "optdesign"], cwd=ROOT,
                             capture_output=True, check=True).stdout
    subprocess.run(["tar", "-x", "-C", str(target)], input=archive, check=True)
    return target


def run(command: list[str], out: Path, mode: str, debug: bool = False,
        code: Path | None = None):
    """(wall seconds, the process's stderr) of one whole run into ``out``."""
    t0 = time.perf_counter()
    done = subprocess.run([*command, "--out", str(out)] + (["--debug"] if debug else []),
                          env=env_of(mode, code), capture_output=True, text=True,
                          cwd=code or ROOT)
    wall = time.perf_counter() - t0
    if done.returncode not in (0, 1):
        raise RuntimeError(f"{' '.join(command)} ({mode}) exited {done.returncode}:\n"
                           f"{done.stderr[-3000:]}")
    return wall, done.stderr


def warm_up(name: str, command: list[str], folder: Path, log) -> None:
    """Run ``command`` with builds started beside it until every NLP it builds, and every
    function it runs on lanes, loads a library (each run starts a few builds: they are
    waited for)."""
    from optdesign.solver import compiled

    where = compiled.folder()
    if where is None or compiled.compiler() is None:
        log("no cache folder or no C compiler: both modes run on the virtual machine")
        return
    for k in range(WARM_UP_ROUNDS):
        _, err = run(command, folder / f"{name.split()[0]}-warm{k}", "on", debug=True)
        while compiled.builds_under_way(where):
            time.sleep(1.0)
        missing = err.count("compiling the NLP's derivatives beside") + \
            err.count("compiling a function's lanes beside") + \
            err.count("a build is under way")
        log(f"{name}: warm-up run {k + 1}: {err.count('derivatives compiled:')} NLP loads "
            f"from libraries, {missing} without")
        if not missing:
            return
    log(f"{name}: some NLPs still without a library after {WARM_UP_ROUNDS} runs")

"""The NLP's compiled derivatives (optdesign.solver.compiled): the same answer to the last bit,
a library loaded only when it is the user's own, intact and built for this NLP, a build
beside the solve (one per NLP), and the virtual machine wherever there is no compiler.

One library is built for the module (Vergov's variator at 3 sections, the smallest NLP of the
shipped problems: about ten seconds of gcc), by the path a solve takes: started beside it as a
detached process and waited for here.
"""
import logging
import os
import shutil
import time

import casadi as ca
import pytest

from optdesign.numerics import user_cache

from optdesign.commands.warmup import recipes_of
from optdesign.numerics import c_library
from optdesign.problem.loader import problem_from_dict
from optdesign.solver import built as kept_nlps
from optdesign.solver import compiled, solve
from tests.conftest import ROOT, file_data, run_main

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="no gcc on PATH")

VERGOV = ROOT / "problems" / "vergov_solve.yaml"
START = compiled.start


def vergov_data() -> dict:
    data = file_data(VERGOV, design__sections=3)
    data["solver"]["workers"] = 1          # one process: its log lines reach caplog
    return data


def recipe_of(problem) -> compiled.Recipe:
    [(_, rec)] = recipes_of(problem)
    return rec


def nlp_files(where) -> list[str]:
    """The names of the NLPs' files in the cache folder (the lanes' code, compiled and not,
    the kinematics' stages, the lanes' records and the Sobol samples kept beside them,
    numerics/lanes.py, numerics/native_lanes.py, numerics/angle_lanes.py,
    numerics/lanes_index.py and numerics/sobol.py, aside, and the notes of the checks that
    passed, numerics/user_cache.py)."""
    return sorted(p.name for p in where.iterdir()
                  if not p.name.startswith(("lanes-", "sobol-", "native-lanes-",
                                            "angle-stages-", "kept-lanes-"))
                  and not p.name.endswith(user_cache.CHECKED))


def wait_for_build(where, name, timeout=300.0) -> None:
    end = time.monotonic() + timeout
    while compiled.building(where, name):
        assert time.monotonic() < end, "the build did not end"
        time.sleep(0.2)


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """(the cache folder, the problem, its recipe, its library), the library built by a
    solve's own path: started beside it, detached."""
    cache = tmp_path_factory.mktemp("cache")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("XDG_CACHE_HOME", str(cache))
        mp.setenv(compiled.VARIABLE, "on")
        problem = problem_from_dict(vergov_data())
        rec = recipe_of(problem)
        where = compiled.folder()
        assert compiled.library(rec, where) is None
        solve(problem)                  # no library: the VM, and a build beside
        assert compiled.building(where, rec.name)
        assert compiled.start(rec, where) is None          # one build per NLP
        wait_for_build(where, rec.name)
        path = compiled.library(rec, where)
        assert path is not None, list(where.iterdir())
        yield where, problem, rec, path


@pytest.fixture
def cache(built, monkeypatch):
    """The module's cache folder as the user's, compiled libraries loaded and no build
    started by a solve; no NLP kept from an earlier solve (each test's solves build theirs,
    as a new process would, and keep none built with a patched CasADi)."""
    where, problem, rec, path = built
    monkeypatch.setenv("XDG_CACHE_HOME", str(where.parent))
    monkeypatch.setenv(compiled.VARIABLE, "load")
    kept_nlps.forget()
    yield built
    kept_nlps.forget()


def test_the_cache_folder_is_the_users_own_and_closed(built):
    where = built[0]
    assert where.name == "optdesign"
    assert oct(where.stat().st_mode & 0o777) == oct(0o700)
    assert oct(built[3].stat().st_mode & 0o077) == oct(0)
    assert nlp_files(where) == [built[3].name]                           # no lock, no source


def test_a_solve_with_and_without_the_library_is_the_same_to_the_last_bit(cache, monkeypatch,
                                                                         caplog):
    where, problem, rec, path = cache
    monkeypatch.setenv(compiled.VARIABLE, "off")
    vm = solve(problem)
    monkeypatch.setenv(compiled.VARIABLE, "load")
    with caplog.at_level(logging.DEBUG, logger="optdesign.compiled"):
        lib = solve(problem)
    assert str(path) in caplog.text                    # the library was the one used
    assert vm.status == lib.status == "optimal"
    assert lib.delta == vm.delta and lib.ratio == vm.ratio          # bit for bit
    assert lib.design == vm.design
    assert lib.iterations == vm.iterations
    assert [p.delta for p in lib.per_phase] == [p.delta for p in vm.per_phase]


def test_a_solve_made_from_the_nlps_record_builds_no_graph_and_is_the_same(cache,
                                                                           monkeypatch):
    """The first solve that finds the library builds the NLP's graph and keeps its record
    beside the library (optdesign.solver.nlp_memo); the next process's solve (here: the
    process's NLPs forgotten) makes the NLP from the record, builds no graph, loads the
    same library and answers the same to the last bit."""
    from optdesign.solver.nlp import PhaseNLP

    where, problem, rec, path = cache
    first = solve(problem)
    assert list(where.glob("nlp-record-*.json"))
    kept_nlps.forget()
    builds, loaded = [], []
    real_build, real_nlpsol = PhaseNLP._build, compiled.nlpsol_of
    monkeypatch.setattr(PhaseNLP, "_build", lambda self: builds.append(self.count) or
                        real_build(self))
    monkeypatch.setattr(compiled, "nlpsol_of", lambda name, lib, opts: loaded.append(lib) or
                        real_nlpsol(name, lib, opts))
    again = solve(problem)
    assert builds == [] and loaded == [path]
    assert (again.status, again.delta, again.ratio, again.design, again.iterations) == \
        (first.status, first.delta, first.ratio, first.design, first.iterations)
    assert [p.delta for p in again.per_phase] == [p.delta for p in first.per_phase]


def _falls_back(rec, problem, monkeypatch) -> list:
    """The builds a solve of ``problem`` starts (recorded, not run), asserting it ran on the
    virtual machine."""
    started = []
    monkeypatch.setenv(compiled.VARIABLE, "on")
    monkeypatch.setattr(compiled, "start", lambda r, w, **kw: started.append(r.digest))
    loaded = []
    real = ca.nlpsol
    monkeypatch.setattr(compiled.ca, "nlpsol",
                        lambda name, kind, what, opts: loaded.append(what) or
                        real(name, kind, what, opts))
    assert solve(problem).status == "optimal"
    assert loaded and all(isinstance(w, dict) for w in loaded)    # the symbolic NLP: the VM
    return started


def test_a_corrupt_library_is_ignored_and_rebuilt(cache, tmp_path, monkeypatch):
    """In a cache of its own: a library this process has loaded stays mapped under its path
    (a file replaced under it changes nothing the process sees)."""
    where, problem, rec, path = cache
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    mine = compiled.folder() / path.name
    flipped = bytearray(path.read_bytes())
    flipped[len(flipped) // 2] ^= 1                          # one bit changed
    mine.write_bytes(bytes(flipped))
    os.chmod(mine, 0o700)
    assert compiled.library(rec, mine.parent) is None
    mine.write_bytes(path.read_bytes()[:4096])               # a library cut short
    assert compiled.library(rec, mine.parent) is None
    assert _falls_back(rec, problem, monkeypatch) == [rec.digest]
    monkeypatch.setattr(compiled, "start", START)
    [(_, rebuilt, seconds, note)] = compiled.warm_up([rec], mine.parent)
    assert note == "compiled" and rebuilt == mine and seconds > 0
    assert compiled.library(rec, mine.parent) == mine
    assert mine.read_bytes() == path.read_bytes()           # the same build, byte for byte


@pytest.mark.parametrize("mode", [0o720, 0o702])
def test_a_library_others_may_write_is_ignored(cache, monkeypatch, mode):
    where, problem, rec, path = cache
    try:
        os.chmod(path, mode)
        assert compiled.library(rec, where) is None
        assert _falls_back(rec, problem, monkeypatch) == [rec.digest]
    finally:
        os.chmod(path, 0o700)
    assert compiled.library(rec, where) == path


def test_a_library_built_for_another_nlp_is_ignored(cache, monkeypatch):
    """A stale library: in the place of one NLP's, built for another."""
    where, problem, rec, path = cache
    data = vergov_data()
    data["design"]["XD"] = {"lower": 120, "upper": 500, "initial": 292}     # another scale
    other = problem_from_dict(data)
    stale = recipe_of(other)
    assert stale.digest != rec.digest
    target = where / f"{stale.name}.so"
    shutil.copy(path, target)
    try:
        assert compiled.library(stale, where) is None
        assert _falls_back(stale, other, monkeypatch) == [stale.digest]
    finally:
        target.unlink()


def test_without_a_compiler_the_solve_runs_on_the_virtual_machine(tmp_path, monkeypatch,
                                                                  capsys):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.setenv(compiled.VARIABLE, "on")
    monkeypatch.setenv("PATH", str(tmp_path / "empty"))
    assert compiled.compiler() is None
    problem = problem_from_dict(vergov_data())
    rec = recipe_of(problem)
    where = compiled.folder()
    assert compiled.start(rec, where) is None
    r = solve(problem)
    assert r.status == "optimal"
    assert nlp_files(where) == []                       # nothing started, nothing left
    code, out = run_main(["warm-up", VERGOV])
    assert code == 1 and out == ""
    assert "no C compiler (gcc) on PATH" in capsys.readouterr().err


def test_a_failed_build_is_noted_and_not_started_again(tmp_path, monkeypatch, caplog):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.setattr(c_library, "COMPILER", "false")         # a compiler that fails
    problem = problem_from_dict(vergov_data())
    rec = recipe_of(problem)
    where = compiled.folder()
    child = compiled.start(rec, where, detached=False)
    child.communicate()
    assert child.returncode == 1
    assert compiled.library(rec, where) is None
    assert (where / f"{rec.name}.failed").read_text().startswith("RuntimeError: ")
    assert nlp_files(where) == [f"{rec.name}.failed"]
    with caplog.at_level(logging.DEBUG, logger="optdesign.compiled"):
        assert compiled.start(rec, where) is None
    assert "an earlier build" in caplog.text


def test_one_build_beside_solves_at_a_time(tmp_path, monkeypatch, caplog):
    """A build of another NLP under way (its lock names a running process): a solve starts
    none of its own, so a run over many distinct problems never starts a compiler each."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    rec = recipe_of(problem_from_dict(vergov_data()))
    where = compiled.folder()
    (where / "another-nlp.lock").write_text(str(os.getpid()))
    assert compiled.builds_under_way(where) == 1
    with caplog.at_level(logging.DEBUG, logger="optdesign.compiled"):
        assert compiled.start(rec, where) is None
    assert "a build is under way" in caplog.text
    assert not (where / f"{rec.name}.lock").exists()
    (where / "another-nlp.lock").write_text("999999999")        # its process has ended
    assert compiled.builds_under_way(where) == 0


def test_warm_up_prints_where_the_libraries_are(cache, capsys, write_problem):
    """... and keeps each NLP's record beside its library: the first solve after it builds
    no graph (optdesign.solver.nlp_memo)."""
    where, problem, rec, path = cache
    for record in where.glob("nlp-record-*.json"):
        record.unlink()
    code, out = run_main(["warm-up", write_problem(vergov_data())])
    assert code == 0
    assert len(list(where.glob("nlp-record-*.json"))) == 1
    nlp, *lanes = out.strip().splitlines()
    assert nlp == f"sections = 3: {path} (cached)"
    assert [line.split(":")[0] for line in lanes] == ["sections = 3, kinematics lanes",
                                                      "sections = 3, speeds lanes"]
    assert all(f" {where}/native-lanes-" in line for line in lanes)
    code, _ = run_main(["warm-up", write_problem("name: x\nmechanism: nothing\n")])
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "p.yaml" in err[0]


def test_the_library_is_named_by_the_nlp_and_the_flags(cache, monkeypatch):
    where, problem, rec, path = cache
    assert recipe_of(problem).digest == rec.digest          # the same NLP, the same name
    assert recipe_of(problem_from_dict(vergov_data() | {"name": "other"})).digest == rec.digest
    monkeypatch.setattr(compiled, "FLAGS", ("-O2", "-shared", "-fPIC"))
    assert recipe_of(problem).digest != rec.digest


def _serialized(rec, where):
    """``rec``'s function written where a build reads it (as :func:`compiled.start` does)."""
    (where / f"{rec.name}.casadi").write_text(rec.serialized)
    return f"{rec.name}.casadi"


def test_code_too_long_to_compile_is_not_compiled(tmp_path, monkeypatch):
    """Generated code past MAX_CODE_BYTES is not handed to a compiler (a four-bar at 16
    phases with its peak acceleration bounded and minimised generated 145 MB, on which gcc
    took a core for half an hour): the build is noted as failed, naming the size, and leaves
    nothing else behind."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.chdir(tmp_path)                 # (a build changes the working folder)
    monkeypatch.setattr(c_library, "MAX_CODE_BYTES", 1000)
    rec = recipe_of(problem_from_dict(vergov_data()))
    where = compiled.folder()
    with pytest.raises(RuntimeError, match="generated code is .* MB, more than 0 MB"):
        c_library.build(where, rec.digest, rec.kind, rec.hessian, shutil.which("gcc"),
                        _serialized(rec, where))
    assert (where / f"{rec.name}.failed").read_text().startswith(
        "RuntimeError: its generated code is")
    assert nlp_files(where) == [f"{rec.name}.failed"]


def test_a_compiler_past_its_cpu_seconds_is_ended(tmp_path, monkeypatch):
    """A compiler that computes on past MAX_COMPILER_CPU_S (here a loop that never ends, given
    one second) is ended by the limit, and the build noted as failed for it."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(c_library, "MAX_COMPILER_CPU_S", 1)
    endless = tmp_path / "endless-gcc"
    endless.write_text("#!/bin/sh\nwhile :; do :; done\n")
    endless.chmod(0o755)
    rec = recipe_of(problem_from_dict(vergov_data()))
    where = compiled.folder()
    t0 = time.monotonic()
    with pytest.raises(RuntimeError, match="took more than 1 CPU seconds"):
        c_library.build(where, rec.digest, rec.kind, rec.hessian, str(endless),
                        _serialized(rec, where))
    assert time.monotonic() - t0 < 60
    assert "CPU seconds" in (where / f"{rec.name}.failed").read_text()
    assert nlp_files(where) == [f"{rec.name}.failed"]


def test_what_a_build_that_died_left_is_removed_when_the_next_build_starts(tmp_path,
                                                                            monkeypatch):
    """A build killed on its way (a machine stopped, a kill) leaves its working folder (the
    generated C, up to MAX_CODE_BYTES) and its serialised function: the next
    build removes both, and nothing of a build under way, nothing a link names, nothing of
    another pattern."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.setattr(c_library, "COMPILER", "false")         # a build that ends at once
    where = compiled.folder()
    dead, live = "nlp-" + "a" * 40, "native-lanes-" + "b" * 40
    (where / f"{dead}.lock").write_text("999999999")             # its process has ended
    (where / f"{live}.lock").write_text(str(os.getpid()))        # a build under way
    for name in (dead, live):
        (where / f".{name}.k3j_x9a1").mkdir()
        (where / f".{name}.k3j_x9a1" / "nlp_deps.c").write_text("int x;")
        (where / f".{name}.casadi.q8z2mm1t.tmp").write_text("serialised")
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "keep.c").write_text("kept")
    (where / f".{dead}.linked77").symlink_to(outside)            # a link: not followed
    (where / ".notes.tmp").write_text("another pattern")
    (where / f"{dead}.so").write_text("a library")
    removed = c_library.swept(where)
    assert sorted(removed) == [f".{dead}.casadi.q8z2mm1t.tmp", f".{dead}.k3j_x9a1"]
    assert (outside / "keep.c").read_text() == "kept"
    assert (where / f".{dead}.linked77").is_symlink()
    assert (where / f".{live}.k3j_x9a1" / "nlp_deps.c").exists()
    assert (where / f".{live}.casadi.q8z2mm1t.tmp").exists()
    assert (where / ".notes.tmp").exists() and (where / f"{dead}.so").exists()
    # a build that starts sweeps first (its own name's leftovers too)
    (where / f".{dead}.k3j_x9a1").mkdir()
    rec = recipe_of(problem_from_dict(vergov_data()))
    (where / f".{rec.name}.zz81_q2w").mkdir()
    child = compiled.start(rec, where, detached=False)
    child.communicate()
    assert not (where / f".{dead}.k3j_x9a1").exists()
    assert not (where / f".{rec.name}.zz81_q2w").exists()

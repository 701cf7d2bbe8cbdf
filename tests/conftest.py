"""Shared fixtures: the paper's design, a writer of problem files, headless Chromium."""
import atexit
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
# every command of the suite runs in a process of its own, and none leaves a warm server
# behind; tests/warm turn the server on for themselves
os.environ["OPTDESIGN_SERVER"] = "off"
# no compiled library of the user's cache is loaded, and no solve starts a compiler beside
# the suite (optdesign.solver.compiled): tests/solve/test_compiled.py builds its own
os.environ["XDG_CACHE_HOME"] = tempfile.mkdtemp(prefix="optdesign-test-cache-")
atexit.register(shutil.rmtree, os.environ["XDG_CACHE_HOME"], True)
os.environ["OPTDESIGN_COMPILE"] = "load"
#: The suite's heaviest files (wall seconds on two busy cores, 2026-12-03, the two
#: simulation files' after their reductions of that day), run first: the Makefile hands out
#: whole files (``--dist loadfile``) in collection order (``--no-loadscope-reorder``;
#: pytest-xdist would otherwise order them by their count of tests and leave the few long
#: ones for last), so the two workers end together, the light files last. A file missing here
#: only runs in its usual place; a stale order costs balance, never a result.
HEAVIEST_FIRST = (
    "test_fuzz_cli.py",                     # 65
    "pareto/test_notebook.py",              # 58
    "solve/test_verdicts.py",               # 53
    "dynamics/test_stiffness_sweep.py",     # 50
    "warm/test_warm_server.py",             # 41
    "solve/test_oracle.py",                 # 35
    "dynamics/test_simulate.py",            # 35
    "test_split_figure.py",                 # 34
    "solve/test_robust.py",                 # 30
    "dynamics/test_outcomes.py",            # 29
    "test_one_delta.py",                    # 29
    "warm/test_hostile_callers.py",         # 28
    "test_workshop.py",                     # 24
    "test_faults.py",                       # 24
    "test_quantity_worst.py",               # 21
    "explorer/test_browser.py",             # 20
    "pareto/test_against.py",               # 20
    "solve/test_built.py",                  # 20
    "pareto/test_turned_back_front.py",     # 19
    "solve/test_reachable.py",              # 18
)


def pytest_collection_modifyitems(items):
    """The files of :data:`HEAVIEST_FIRST` first, in its order; the rest as collected."""
    rank = {ROOT / "tests" / name: i for i, name in enumerate(HEAVIEST_FIRST)}
    items.sort(key=lambda item: rank.get(Path(item.path), len(rank)))


PAPER = dict(l0=225.0, l1=20.0, l2=225.0, l2_prime=100.0, l3=56.0, phases=6)


@pytest.fixture(autouse=True)
def _no_nlp_built_under_a_patch(request):
    """A test that patches code (``monkeypatch``) keeps no NLP for the tests after it: an
    NLP built under a patched mechanism, criterion or option would be given to a later solve
    of an equal problem (optdesign.solver.built). No test shares a kept child with another
    (optdesign.kept_children): one forked before a patch would run the code unpatched, one
    forked under it the patched code, and a test may count the children it leaves."""
    from optdesign import kept_children

    kept_children.end_all()
    yield
    kept_children.end_all()
    if "monkeypatch" in request.fixturenames:
        from optdesign.solver import built
        built.forget()


@pytest.fixture
def own_cache(tmp_path, monkeypatch):
    """An empty cache folder of the user's own, read and written (numerics/user_cache.py)."""
    from optdesign.numerics import c_library

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.setenv("OPTDESIGN_COMPILE", "on")
    # no compiler started beside these tests (the compiled lanes' own: test_native_lanes.py)
    monkeypatch.setattr(c_library, "COMPILER", "optdesign-test-no-compiler")
    return tmp_path / "optdesign"


def kept_files(where: Path, prefix: str) -> list[Path]:
    """The files of one kind (``lanes-``, ``sobol-``) kept in the cache folder ``where``."""
    return sorted(p for p in where.iterdir() if p.name.startswith(prefix))


@pytest.fixture
def paper_design():
    from optdesign.evaluation.design import Design
    return Design("fourbar_converter", dict(PAPER))


@pytest.fixture
def write_problem(tmp_path):
    """Write a problem mapping (or raw text) to a YAML file and return its path."""
    def write(data, name="p.yaml"):
        path = tmp_path / name
        path.write_text(data if isinstance(data, str) else yaml.safe_dump(data))
        return path
    return write


def file_data(path, **changes) -> dict:
    """A problem file's mapping with keys changed: ``name=...`` sets a top-level key,
    ``section__key=...`` a key of a section."""
    data = yaml.safe_load(Path(path).read_text())
    for key, value in changes.items():
        section, _, sub = key.partition("__")
        if sub:
            data.setdefault(section, {})[sub] = value
        else:
            data[key] = value
    return data


def near_starter(model, rng, spread: float) -> list[float]:
    """The lengths of ``model``'s starter design (``optdesign init``'s), each moved by up to
    ``spread`` of itself at random: a design of the mechanism that assembles."""
    start = {k: v["initial"] if isinstance(v, dict) else v
             for k, v in model.starter["design"].items()}
    return [start[n] * rng.uniform(1.0 - spread, 1.0 + spread) for n in model.lengths]


def base_problem(**changes):
    data = yaml.safe_load((ROOT / "problems" / "sharkov2022.yaml").read_text())
    data.update(changes)
    return data


def run_main(argv) -> tuple[int, str]:
    """(exit code, stdout) of one in-process ``optdesign`` command."""
    import contextlib
    import io

    from optdesign.cli import main

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = main([str(a) for a in argv])
    return code, out.getvalue()


@pytest.fixture
def add_quantity(tmp_path, monkeypatch):
    """Add a quantity module (its file name and text) to the quantities' catalog for one
    test, as docs/architecture.md's worked example does: a folder on the catalog's path. The
    declarations computed at import (the pareto: section's resolutions) are imported first,
    over the catalog as shipped, so no other test sees the added quantity."""
    import optdesign.fronts.section  # noqa: F401
    import optdesign.quantities as quantities
    from optdesign.quantities import catalog

    def add(file_name: str, text: str) -> None:
        folder = tmp_path / "more_quantities"
        folder.mkdir(exist_ok=True)
        (folder / file_name).write_text(text)
        if str(folder) not in catalog.__path__:
            monkeypatch.setattr(catalog, "__path__", [*catalog.__path__, str(folder)])
        quantities._registry.cache_clear()

    yield add
    quantities._registry.cache_clear()


#: Chromium's flags for a headless run that reaches no network
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync"]


@pytest.fixture(scope="session")
def chromium():
    """Headless Chromium's path: the Debian package, installed as root with apt-get when
    missing; the test is skipped with the reason otherwise."""
    path = shutil.which("chromium") or ("/usr/bin/chromium"
                                        if os.path.exists("/usr/bin/chromium") else None)
    if path is None and hasattr(os, "geteuid") and os.geteuid() == 0 and \
            shutil.which("apt-get"):
        env = os.environ | {"DEBIAN_FRONTEND": "noninteractive"}
        for step in (["apt-get", "install", "-y", "chromium"],          # lists present
                     ["apt-get", "update"], ["apt-get", "install", "-y", "chromium"]):
            subprocess.run(step, capture_output=True, timeout=900, check=False, env=env)
            if shutil.which("chromium"):
                break
        path = shutil.which("chromium")
    if path is None:
        pytest.skip("headless Chromium not found: install the Debian package `chromium` "
                    "(apt-get install -y chromium, as root) to render the pages")
    return path


def chromium_run(chromium, tmp_path, *args) -> str:
    """Chromium's stdout for ``args`` (e.g. ``--screenshot=F.png``), with a profile of its
    own under ``tmp_path``."""
    cmd = [chromium, *FLAGS, f"--user-data-dir={tmp_path / 'profile'}", *args]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=60, check=False)
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout


@pytest.fixture(scope="session")
def solved_disc(tmp_path_factory):
    """``optdesign solve problems/sharkov2022_disc.yaml --no-plots`` once per session: (its
    folder, its result.json). Its files are read, never changed, by the tests that use it."""
    import json

    out = tmp_path_factory.mktemp("solved_disc")
    code, _ = run_main(["solve", ROOT / "problems" / "sharkov2022_disc.yaml", "--out", out,
                        "--no-plots"])
    assert code == 0
    return out, json.loads((out / "result.json").read_text())


def executed_notebook(name: str, monkeypatch, edit=None) -> tuple:
    """notebooks/NAME run top to bottom in a python3 kernel (installed into this venv when
    it has none), with this checkout on PYTHONPATH; ``edit(nb)`` may change it first.
    Returns the notebook and every code cell's outputs."""
    import sys

    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    from jupyter_client.kernelspec import KernelSpecManager, NoSuchKernel
    try:
        KernelSpecManager().get_kernel_spec("python3")
    except NoSuchKernel:                 # a fresh venv without a kernelspec: install one
        from ipykernel.kernelspec import install
        install(prefix=sys.prefix)
    monkeypatch.setenv("PYTHONPATH", str(ROOT))
    nb = nbformat.read(ROOT / "notebooks" / name, as_version=4)
    if edit is not None:
        edit(nb)
    client = nbclient.NotebookClient(nb, kernel_name="python3", timeout=120,
                                     resources={"metadata": {"path": str(ROOT / "notebooks")}})
    client.execute()
    return nb, [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])]


class SignalLeft(UserWarning):
    """A test left the process's Ctrl-C handler changed (restored for the next test)."""


@pytest.fixture(autouse=True)
def _ctrl_c_as_python_sets_it():
    """Every test starts with Python's own SIGINT handler, and one that leaves another behind
    is named in the warnings summary (the tests of Ctrl-C need the default; a worker of the
    suite once ran with SIGINT ignored, left so by an earlier test file)."""
    import signal
    import warnings

    signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    left = signal.getsignal(signal.SIGINT)
    if left is not signal.default_int_handler:
        signal.signal(signal.SIGINT, signal.default_int_handler)
        warnings.warn(SignalLeft(f"this test left SIGINT handled by {left!r}"))

"""Start-up: a command imports only what it uses.

Each check runs in a fresh interpreter (what this test process imported says nothing) and
lists the heavy packages found in ``sys.modules`` afterwards: CasADi, pandas, matplotlib,
Dask, SciPy and their like cost from a tenth of a second to most of one each to import.
"""
import json
import subprocess
import sys

from optdesign.cli import COMMANDS
from tests.conftest import ROOT

#: the packages worth a look, and SciPy's subpackages that a command may need one of without
#: the others (scipy.optimize brings linalg, sparse, special and fft along)
HEAVY = ("casadi", "pandas", "matplotlib", "dask", "distributed", "scipy", "scipy.optimize",
         "scipy.stats", "scipy.integrate", "ezdxf", "tqdm", "PIL")

#: prints, after running CODE, which of HEAVY are in sys.modules
PROBE = ("import sys, json\n{code}\n"
         "print(json.dumps([n for n in {heavy!r} if n in sys.modules]))\n")


def _start(code: str, env: dict | None = None) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-c", PROBE.format(code=code, heavy=HEAVY)],
                            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, env=env)


def _heavy(proc: subprocess.Popen) -> set[str]:
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    return set(json.loads(out.splitlines()[-1]))


def test_the_command_modules_import_nothing_heavy():
    """Building the command line imports every command's module: each must stay light (its
    run() imports the library it needs)."""
    running = {name: _start(f"import {name}") for name in COMMANDS}    # at once: ~0.1 s each
    pulled = {name: _heavy(proc) for name, proc in running.items()}
    assert pulled == {name: set() for name in COMMANDS}


def test_analyze_imports_only_what_one_exact_evaluation_needs():
    proc = _start("from optdesign.cli import main\n"
                  "assert main(['analyze', 'problems/sharkov2022.yaml']) == 0")
    allowed = {
        "casadi",              # the mechanism's symbolic functions, evaluated exactly
        "scipy",               # the package of the two below
        "scipy.optimize",      # brentq: the envelope's switch and stationary points
    }
    found = _heavy(proc)
    assert found <= allowed, f"analyze imported {sorted(found - allowed)}"
    assert {"matplotlib", "pandas", "dask", "scipy.stats", "tqdm"}.isdisjoint(found)


def test_a_solve_reads_its_sobol_sample_from_the_cache_without_scipy_stats(tmp_path):
    """scipy.stats is half a second of imports, needed only to draw the screening's scrambled
    Sobol sample: the first process draws it and keeps it in the user's cache, a later one
    reads it back (optdesign/numerics/sobol.py)."""
    import os

    env = dict(os.environ, XDG_CACHE_HOME=str(tmp_path), OPTDESIGN_COMPILE="load")
    code = ("from optdesign import solve\n"
            "assert solve('problems/sharkov2022_disc.yaml').status == 'optimal'")
    found = [_heavy(_start(code, env)) for _ in range(2)]      # one after the other
    assert "scipy.stats" in found[0] and "scipy.stats" not in found[1]
    assert list((tmp_path / "optdesign").glob("sobol-*.npy"))


def test_a_designs_figures_import_nothing_after_their_warm_up(tmp_path):
    """The figures of a problem's design (``solve``'s speeds and linkage, the front's knee)
    label it with its exact δ, which needs SciPy's root finder: the figures' process imports
    it while the command computes (``warm_up(problem)``), not each figure's forked process
    again after the answer (half a second each)."""
    code = (f"from optdesign.problem.loader import load_problem\n"
            f"from optdesign.figures.design import warm_up\n"
            f"from optdesign.commands.files import _mechanism_png, _speeds_png\n"
            f"problem = load_problem('problems/sharkov2022_disc.yaml')\n"
            f"values = problem.start_values() | {{'phases': problem.counts()[0]}}\n"
            f"warm_up(problem)\n"
            f"warm = set(sys.modules)\n"
            f"_speeds_png(problem, values, {str(tmp_path / 'speeds.png')!r}, 'file')\n"
            f"_mechanism_png(problem, values, {str(tmp_path / 'mechanism.png')!r}, 'file')\n"
            f"print(json.dumps([n for n in {HEAVY!r} if n in sys.modules and n not in warm]))\n"
            f"sys.stdout.flush()\n"
            f"import os; os._exit(0)      # this line is the last: the probe's own not printed")
    found = _heavy(_start(code))
    assert found == set(), f"the figures imported {sorted(found)} after the warm-up"
    assert (tmp_path / "speeds.png").exists() and (tmp_path / "mechanism.png").exists()

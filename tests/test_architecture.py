"""The shape the code promises in docs/architecture.md: no import cycle, and a new constraint
added in one place (a worked example a reader can copy)."""
import ast
from pathlib import Path

from optdesign.criteria import LengthConstraint
from optdesign.mechanisms import get_mechanism
from optdesign.problem import load_problem
from optdesign.solve import solve, verify
from tests.conftest import ROOT

PACKAGE = ROOT / "optdesign"


def _module(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(path: Path) -> set[str]:
    """Every optdesign module ``path`` imports, at the top or inside a function."""
    here = _module(path).split(".")
    package = here if path.name == "__init__.py" else here[:-1]
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            base = package[:len(package) - node.level + 1] if node.level else []
            target = ".".join(base + (node.module.split(".") if node.module else []))
            if node.level or target.startswith("optdesign"):
                out.add(target)
                out.update(f"{target}.{a.name}" for a in node.names)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names if a.name.startswith("optdesign"))
    return out


def test_no_module_imports_a_module_that_imports_it_back():
    modules = {_module(p): p for p in PACKAGE.rglob("*.py")}
    graph = {m: {t for t in _imports(p) if t in modules and t != m} for m, p in modules.items()}
    cycles = sorted((a, b) for a in graph for b in graph[a]
                    if a in graph.get(b, ()) and a < b and not b.startswith(a + ".")
                    and not a.startswith(b + "."))
    assert cycles == []


def test_a_new_constraint_is_one_object(monkeypatch):
    """Worked example (docs/architecture.md): rockers at least 30 mm long. One object gives
    the NLP its row, the exact check its test and the report its column."""
    mech = get_mechanism("fourbar_converter")
    own = mech.criteria

    def criteria(constraints, options):
        return own(constraints, options) + [
            LengthConstraint("min_rocker", lambda p: p["l3"], lower=30.0, column="rocker")]

    monkeypatch.setattr(mech, "criteria", criteria)
    problem = load_problem(ROOT / "problems" / "sharkov2022_disc.yaml")
    r = solve(problem)
    assert r.status == "optimal"
    assert r.design["l3"] >= 30.0 - 1e-6                 # the free optimum has l3 = 26.9
    assert r.delta > 0.140214                            # so the optimum moved
    assert "min_rocker" in verify(problem, r.design | {"l3": 25.0}).violations

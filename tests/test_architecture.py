"""The shape the code promises in docs/architecture.md: no import cycle, and a new constraint,
objective, mechanism or section added in one place each (worked examples a reader can copy)."""
import ast
import math
from dataclasses import dataclass
from pathlib import Path

import casadi as ca
import pytest
import yaml

from optdesign.analyses.analyze import analyze
from optdesign.quantities.criteria import OBJECTIVES, LengthConstraint, Objective
from optdesign.errors import ProblemError
from optdesign.mechanisms import REGISTRY, Mechanism, VariableSpec, get_mechanism
from optdesign.problem.loader import SECTION_PARSERS, load_problem, problem_from_dict
from optdesign.solver import solve, verify
from tests.conftest import ROOT

PACKAGE = ROOT / "optdesign"


def _module(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(path: Path, modules) -> set[str]:
    """Every optdesign module ``path`` imports: at the top or inside a function, by
    ``import_module`` of a literal name, of an f-string's literal prefix (every module under
    it), or by a registry's ``"module"`` or ``"module:Class"`` string."""
    here = _module(path).split(".")
    package = here if path.name == "__init__.py" else here[:-1]
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            base = package[:len(package) - node.level + 1] if node.level else []
            target = ".".join(base + (node.module.split(".") if node.module else []))
            if node.level or target.startswith("optdesign"):
                named = {f"{target}.{a.name}" for a in node.names}
                out.update(named & set(modules) or {target})
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names if a.name.startswith("optdesign"))
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) \
                and "." in node.value and node.value.split(":")[0] in modules:
            out.add(node.value.split(":")[0])            # a registry's "module" or "module:Class"
        elif isinstance(node, ast.Call) and getattr(node.func, "id",
                                                     getattr(node.func, "attr", "")) == "import_module":
            arg = node.args[0] if node.args else None
            if isinstance(arg, ast.Constant) and str(arg.value).startswith("optdesign"):
                out.add(arg.value)
            elif isinstance(arg, ast.JoinedStr) and isinstance(arg.values[0], ast.Constant):
                prefix = arg.values[0].value
                assert prefix.startswith("optdesign."), f"{path}: import_module({prefix!r}...)"
                out.update(m for m in modules if m.startswith(prefix))
    return out


def _graph() -> dict[str, set[str]]:
    modules = {_module(p): p for p in PACKAGE.rglob("*.py")}
    return {m: {t for t in _imports(p, modules) if t in modules and t != m}
            for m, p in modules.items()}


def _strongly_connected(graph: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's components of more than one node (iterative: no recursion limit)."""
    index, low, on_stack, stack, found = {}, {}, set(), [], []
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph.get(child, ())))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def _packages_at(graph: dict[str, set[str]], depth: int) -> dict[str, set[str]]:
    """The import graph between the packages ``depth`` levels under optdesign: an edge where
    any module of one imports any module of the other (a package's own modules, and the
    root's lazy door ``optdesign.__init__``, aside)."""
    def group(module):
        return ".".join(module.split(".")[:depth + 1])

    out: dict[str, set[str]] = {}
    for module, targets in graph.items():
        if module.count(".") < depth:
            continue
        out.setdefault(group(module), set()).update(
            group(t) for t in targets if t.count(".") >= depth and group(t) != group(module))
    return out


def test_no_circle_among_modules():
    assert _strongly_connected(_graph()) == []


def test_no_circle_among_packages_at_any_depth():
    graph = _graph()
    depth = max(m.count(".") for m in graph)
    assert {d: _strongly_connected(_packages_at(graph, d)) for d in range(1, depth)} == \
        {d: [] for d in range(1, depth)}


def test_the_check_finds_a_circle_when_there_is_one():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert _strongly_connected(graph) == [["a", "b", "c"]]
    assert _packages_at({"optdesign.p.x": {"optdesign.q.y"}, "optdesign.q.y": {"optdesign.p.z"},
                         "optdesign.p.z": set()}, 1) == {"optdesign.p": {"optdesign.q"},
                                                         "optdesign.q": {"optdesign.p"}}


def test_the_package_root_holds_only_its_doors_and_leaves():
    """The root keeps the API, the command line, and the leaves every layer needs (errors,
    key declarations, child-process lifetime and the children kept, the limits of counts);
    everything else lives in a named package."""
    flat = sorted(p.name for p in PACKAGE.glob("*.py"))
    assert flat == ["__init__.py", "__main__.py", "api.py", "cli.py", "declarations.py",
                    "errors.py", "kept_children.py", "lifetime.py", "limits.py"]


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


# --------------------------------------------------------------------------- a new objective
class RipplePerRatio(Objective):
    """Worked example: the least ripple per unit of ratio, δ/i."""

    name = "ripple_per_ratio"

    def expression(self, q):
        return q.worst_ripple / q.ratio

    def rank(self, delta, ratio):
        return delta / ratio


def test_a_new_objective_is_one_class_and_one_entry(monkeypatch):
    monkeypatch.setitem(OBJECTIVES, "ripple_per_ratio", RipplePerRatio)
    data = yaml.safe_load((ROOT / "problems" / "sharkov2022_disc.yaml").read_text())
    data["objective"]["minimize"] = "ripple_per_ratio"
    r = solve(problem_from_dict(data))
    assert r.status == "optimal"
    # the least-ripple optimum has δ/i = 0.140205/0.72889 = 0.19236: this one is no worse
    assert r.delta / r.ratio <= 0.140205 / 0.72889 + 1e-6


# --------------------------------------------------------------------------- a new mechanism
class SineRockers(Mechanism):
    """Worked example: n rockers θ_k = (a/100 mm)·sin(φ − 2πk/n), the least a mechanism says.

    With the forward stroke ω_max = a/100·ω1 and ω_min = ω_max·cos(π/n) at the crossings, so
    δ = 2(1 − cos(π/n))/(1 + cos(π/n)): a closed form to check against."""

    name = "sine_rockers"
    source = "worked example (docs/architecture.md)"
    variables = (VariableSpec("a", "mm", "amplitude (regulated)"),
                 VariableSpec("rockers", "-", "rockers and freewheels", integer=True, minimum=2))
    count_variable = "rockers"
    regulating_variable = "a"

    def chain_expressions(self, phi, p, count, options):
        theta = [p["a"] / 100 * ca.sin(phi - 2 * math.pi * k / count) for k in range(count)]
        return {"theta": theta, "cos_mu": [ca.SX(0)] * count,
                "joints": {"O": ca.vertcat(0, 0)}, "links": []}


def test_a_new_mechanism_is_one_class_and_one_registry_line(monkeypatch):
    monkeypatch.setitem(REGISTRY, "sine_rockers", "tests.test_architecture:SineRockers")
    problem = problem_from_dict({"mechanism": "sine_rockers", "input_speed": 10.0,
                                 "design": {"a": 50.0, "rockers": 3}})
    figures = analyze(problem).strokes["forward"]
    c = math.cos(math.pi / 3)
    assert figures.delta == pytest.approx(2 * (1 - c) / (1 + c), abs=1e-12)
    assert figures.omega_max == pytest.approx(0.5 * 10.0, rel=1e-12)


def test_a_new_mechanism_runs_through_the_command_line(monkeypatch, tmp_path):
    """The same class, solved from a problem file by ``optdesign solve``: the count is the
    mechanism's (``rockers``), the solve picks the count of least ripple (δ falls with n)."""
    import json

    from tests.conftest import run_main

    monkeypatch.setitem(REGISTRY, "sine_rockers", "tests.test_architecture:SineRockers")
    path = tmp_path / "sine.yaml"
    path.write_text(yaml.safe_dump({
        "mechanism": "sine_rockers", "input_speed": 10.0,
        "design": {"a": {"lower": 20.0, "upper": 60.0, "initial": 50.0},
                   "rockers": {"choices": [3, 5]}}}))
    code, _ = run_main(["solve", path, "--out", tmp_path / "out", "--no-plots"])
    result = json.loads((tmp_path / "out" / "result.json").read_text())
    c = math.cos(math.pi / 5)
    assert code == 0 and result["status"] == "optimal" and result["design"]["rockers"] == 5
    assert result["delta"] == pytest.approx(2 * (1 - c) / (1 + c), rel=1e-9)
    assert [p["count"] for p in result["per_phase"]] == [3, 5]
    assert result["units"]["rockers"] == "-"


# --------------------------------------------------------------------------- a new section
@dataclass(frozen=True)
class RpmSection:
    """Worked example: a ``rpm:`` section that reports the output speeds in rpm."""

    digits: int

    def analyze(self, problem, result) -> dict:
        f = result.strokes[problem.stroke]
        to_rpm = 60 / (2 * math.pi)
        return {"omega_max_rpm": round(f.omega_max * to_rpm, self.digits),
                "omega_min_rpm": round(f.omega_min * to_rpm, self.digits)}


def parse_rpm(raw, reader) -> RpmSection:
    raw = reader.mapping(raw, "")
    reader.known_keys(raw, "", {"digits"})
    return RpmSection(reader.integer(raw.get("digits", 1), "digits", 0))


def test_a_new_section_is_one_parser_and_one_registry_line(monkeypatch, tmp_path):
    monkeypatch.setitem(SECTION_PARSERS, "rpm", "tests.test_architecture:parse_rpm")
    data = yaml.safe_load((ROOT / "problems" / "sharkov2022.yaml").read_text())
    data["rpm"] = {"digits": 2}
    out = analyze(problem_from_dict(data)).sections["rpm"]
    assert out["omega_max_rpm"] == pytest.approx(39.838 * 60 / (2 * math.pi), abs=0.01)
    data["rpm"] = {"digits": "two"}
    with pytest.raises(ProblemError, match=r"rpm\.digits must be an integer"):
        problem_from_dict(data, where="p.yaml")


# --------------------------------------------------------------------------- a new quantity
DEPTH_MODULE = '''
import casadi as ca

from optdesign.quantities.base import TurnQuantity


class Depth(TurnQuantity):
    name, unit, label, worst = "depth", "mm", "depth below O (mm)", "max"
    meaning = "largest depth of any moving joint below the crank centre O over a turn"

    def expression(self, model, phi, p, count):
        return [-point[1] for point in model["joints"].values() if ca.depends_on(point, phi)]
'''


@pytest.fixture
def depth_quantity(add_quantity):
    """The worked example of docs/architecture.md: one module in the quantities' catalog
    (here a folder added to the catalog's path) and nothing else."""
    add_quantity("depth.py", DEPTH_MODULE)


def test_a_new_quantity_is_one_module(depth_quantity, tmp_path):
    from tests.conftest import run_main

    data = yaml.safe_load((ROOT / "problems" / "housing_disc.yaml").read_text())
    data["constraints"] = {"min_transmission_angle_deg": 40, "min_pin_radius": 125,
                           "depth": {"upper": 300}}
    path = tmp_path / "depth.yaml"
    path.write_text(yaml.safe_dump(data))
    code, out = run_main(["analyze", path, "--json"])
    import json
    first = json.loads(out)
    assert code == 0 and first["units"]["depth"] == "mm"
    assert first["quantities"]["values"]["depth"] > 0
    # a bound on it: held exactly at the optimum, named in the result and its units
    out_dir = tmp_path / "solved"
    code, _ = run_main(["solve", path, "--out", out_dir, "--no-plots"])
    result = json.loads((out_dir / "result.json").read_text())
    assert code == 0 and result["status"] == "optimal"
    depth = result["quantities"]["values"]["depth"]
    assert depth == pytest.approx(300, rel=1e-7) and depth <= 300 * (1 + 1e-7)
    assert any(a["name"] == "depth" for a in result["active"])
    problem = load_problem(path)
    assert verify(problem, result["design"]).feasible
    # an objective over it, and a column of the front's table
    data["objective"] = {"minimize": "depth", "min_ratio": 0.344}
    data["constraints"] = {"min_transmission_angle_deg": 40, "min_pin_radius": 125}
    path.write_text(yaml.safe_dump(data))
    least = solve(load_problem(path))
    assert least.status == "optimal" and least.quantities["values"]["depth"] < depth
    from optdesign.fronts.front import quantity_columns
    assert "depth" in quantity_columns()
    # a front of ripple against it, from the command line: its column in pareto.csv, each
    # point's depth held at the point's ε, each verified exactly
    data["objective"] = {"minimize": "ripple", "min_ratio": 0.344}
    data["pareto"] = {"points": 3, "refine": {"enabled": False}}
    path.write_text(yaml.safe_dump(data))
    code, _ = run_main(["pareto", path, "--against", "depth", "--out", tmp_path / "front",
                        "--no-report", "--workers", "1"])
    front = json.loads((tmp_path / "front" / "pareto.json").read_text())
    assert code == 0 and front["run"]["against"] == "depth"
    assert front["units"]["epsilon"].startswith("mm")
    header = (tmp_path / "front" / "pareto.csv").read_text().splitlines()[0].split(",")
    assert "depth" in header
    held = [q for q in front["points"] if q["status"] == "optimal" and q["epsilon"] is not None]
    assert len(held) >= 2
    swept = load_problem(path)
    for q in held:
        assert q["depth"] <= q["epsilon"] * (1 + 1e-7)
        design = {k: q[k] for k in swept.model.lengths} | {"phases": q["phases"]}
        assert verify(swept, design).feasible

"""Fuzzing the CLI with hostile problem files: whatever a file holds, the command ends with
exit 0, 1 or 2, no traceback, one line on stderr for exit 2 and valid JSON when it prints or
writes JSON (docs/contract.md, "Limits").

Each example is a *recipe*: one of the problems in problems/ and a few mutations of it, drawn
from the keys the loader declares (mechanism variables, solver keys, section keys) and from
the files themselves: wrong types, extreme numbers, unknown and deleted keys, deep nesting,
aliases, duplicate keys, NUL bytes, bytes that are not UTF-8, hostile names. ``analyze`` runs
in-process (fast) for most examples; a few ``solve`` and ``curves`` runs go to subprocesses
under a time limit. Recipes that once failed stay as ``@example`` cases. For a longer hunt:
``OPTDESIGN_FUZZ_EXAMPLES=5000 OPTDESIGN_FUZZ_SUBPROCESS_EXAMPLES=50 pytest
tests/test_fuzz_cli.py``.
"""
from __future__ import annotations

import copy
import io
import json
import math
import os
import signal
import subprocess
import sys
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import yaml
from hypothesis import HealthCheck, event, example, given, settings, strategies as st

from optdesign.cli import main
from tests.conftest import ROOT

PROBLEMS = sorted(p for p in (ROOT / "problems").glob("*.yaml")
                  if not p.stem.startswith("atlas_"))      # atlas files: docs/atlas.md
BASES = {p.stem: yaml.safe_load(p.read_text()) for p in PROBLEMS}
#: seconds an in-process analyze may take before the example counts as a hang
ANALYZE_LIMIT_S = 30
#: seconds a subprocess solve or curves may take
SUBPROCESS_LIMIT_S = 120
#: what keeps a fuzzed solve small (mutations do not touch solver:)
SMALL_SOLVER = {"screen": 16, "starts": 1, "basins": 1, "workers": 1, "max_iter": 15,
                "samples": 16}


def _flat(data, prefix=""):
    """Dotted key paths of a nested mapping."""
    for k, v in data.items():
        path = f"{prefix}{k}"
        yield path
        if isinstance(v, dict):
            yield from _flat(v, path + ".")


def _declared_paths() -> list[str]:
    """Every key path the loader declares, those of the files, and a few unknown ones."""
    from optdesign.driveline.section import KEYS as DRIVELINE
    from optdesign.dynamics.section import KEYS as DYNAMICS
    from optdesign.mechanisms import REGISTRY, get_mechanism
    from optdesign.fronts.section import KEYS as PARETO
    from optdesign.problem.loader import (EXTRA_CONSTRAINT_KEYS, GENERAL_CONSTRAINT_KEYS,
                                          SECTION_PARSERS, SOLVER_INTEGERS, TOP_KEYS)

    paths = set(TOP_KEYS) | set(SECTION_PARSERS)
    for data in BASES.values():
        paths |= set(_flat(data))
    paths |= {f"solver.{k}" for k in [*SOLVER_INTEGERS, "smoothing", "hessian", "peak_samples"]}
    paths |= {f"constraints.{k}" for k in GENERAL_CONSTRAINT_KEYS | EXTRA_CONSTRAINT_KEYS}
    paths |= {f"objective.{k}" for k in ("minimize", "ripple", "min_ratio", "max_ripple")}
    paths |= {"regulation.eccentricity"}
    for name in REGISTRY:
        mech = get_mechanism(name)
        paths |= {f"constraints.{k}" for k in mech.constraint_keys}
        paths |= {f"options.{o.name}" for o in mech.options}
        for v in mech.variables:
            paths |= {f"design.{v.name}"} | {f"design.{v.name}.{b}" for b in (
                ("lower", "upper", "choices") if v.integer else ("lower", "upper", "initial"))}
    for section, keys in (("driveline", DRIVELINE), ("dynamics", DYNAMICS), ("pareto", PARETO)):
        paths |= {f"{section}.{k}" for k in keys}
    paths |= {"colour", "design.l9", "solver.speed", "driveline.colour", "dynamics.motor.c"}
    return sorted(paths)


PATHS = _declared_paths()
#: paths of the files' numbers (and of bounds and lists of them), for the "scale" op
NUMBER_PATHS = sorted({path for data in BASES.values() for path in _flat(data)
                       if path.split(".")[0] in ("input_speed", "design", "constraints",
                                                 "objective", "regulation", "driveline",
                                                 "dynamics", "pareto")})
SOLVE_BASES = sorted(k for k, d in BASES.items()
                     if any(isinstance(v, dict) for v in d["design"].values())
                     and "dynamics" not in d and "driveline" not in d)

HOSTILE = [0, -0.0, -1, 1e-320, 5e-324, 2.2250738585072014e-308, 1e-101, 1e-100, 1e100,
           1e101, 1.7976931348623157e308, float("inf"), float("-inf"), float("nan"), 2**31,
           2**63, 10**30, 10**400, 1e30, 0.5, 2.5, 97, True, False, None, "", "x", "\0",
           "../../../x", "/etc/passwd", "x" * 300, "é" * 150, "a\nb", "1e5", "NaN", [], [1],
           [1.0, 1e-320], {}, {"lower": 1, "upper": 1e9}, {"choices": [2, 10**9]},
           {"lower": 4, "upper": 1e9}, {"lower": 1e-320, "upper": 1e308},
           {"lower": 300, "upper": 100}, {"choices": []}]

TEXT_OPS = ("dup_line", "alias_bomb", "deep_list", "deep_map", "nul", "bad_utf8", "truncate",
            "crlf", "bom", "tab", "anchor_cycle", "merge", "long_scalar", "bigint", "tag",
            "multi_doc")
TAGS = ("!!binary AAAA", "!!python/object/apply:os.system [echo]", "!!set {a}",
        "!!timestamp 2001-13-45", "!!float x", "!!int 1e400", "!!str 5", "!!omap [a: 1]")


# --------------------------------------------------------------------------- recipes
def _set(data, path, value):
    node = data
    keys = path.split(".")
    for k in keys[:-1]:
        if not isinstance(node.get(k), dict):
            node[k] = {}
        node = node[k]
    node[keys[-1]] = value


def _parent(data, path):
    """(the mapping that holds the last key of ``path``, that key), or (None, key)."""
    node = data
    keys = path.split(".")
    for k in keys[:-1]:
        node = node.get(k)
        if not isinstance(node, dict):
            return None, keys[-1]
    return node, keys[-1]


def _drop(data, path):
    node, key = _parent(data, path)
    if node is not None:
        node.pop(key, None)


def _times(value, factor):
    """``value * factor``, an integer too large for a float scaled as infinity."""
    try:
        return value * factor
    except OverflowError:
        return math.inf if (value > 0) == (factor > 0) else -math.inf


def _scale(data, path, factor):
    """Multiply the number at ``path`` (or every number of a list or bounds there)."""
    node, key = _parent(data, path)
    if node is None:
        return
    value = node.get(key)
    if isinstance(value, bool):
        return
    if isinstance(value, (int, float)):
        node[key] = _times(value, factor)
    elif isinstance(value, list):
        node[key] = [_times(v, factor) if isinstance(v, (int, float)) and not isinstance(v, bool)
                     else v for v in value]
    elif isinstance(value, dict):
        for k in list(value):
            _scale(value, k, factor)


def _nested(depth, kind):
    value = 1
    for _ in range(depth):
        value = [value] if kind == "list" else {"k": value}
    return value


def _bomb(levels):
    names = "abcdefghijklmnop"
    items = ["&a [l, l, l, l, l, l, l, l, l]"] + [
        f"&{names[i]} [" + ", ".join([f"*{names[i - 1]}"] * 9) + "]" for i in range(1, levels)]
    return "[" + ", ".join(items) + "]"


def _text_op(text: str, kind: str, arg: int) -> str:
    """One mutation of the file's text (bytes that are not UTF-8 as surrogate escapes)."""
    lines = text.splitlines(keepends=True) or ["\n"]
    i = arg % len(lines)
    head = lines[i].split(":")[0]
    if kind == "dup_line":
        lines.insert(i, lines[i])
    elif kind == "alias_bomb":
        lines[i] = f"{head}: {_bomb(5 + arg % 5)}\n"
    elif kind == "deep_list":
        lines.append("deep: " + "[" * (10 + arg % 6000) + "]" * (10 + arg % 6000) + "\n")
    elif kind == "deep_map":
        n = 10 + arg % 60
        lines.append("".join("  " * d + f"k{d}:\n" for d in range(n)) + "  " * n + "x: 1\n")
    elif kind in ("nul", "bad_utf8", "truncate"):
        pos = arg % (len(text) + 1)
        return text[:pos] + {"nul": "\0", "bad_utf8": "\udcff\udcfe\udcc3",
                             "truncate": ""}[kind] + ("" if kind == "truncate" else text[pos:])
    elif kind == "crlf":
        return text.replace("\n", "\r\n")
    elif kind == "bom":
        return "\ufeff" + text
    elif kind == "tab":
        lines[i] = "\t" + lines[i]
    elif kind == "anchor_cycle":
        lines.append("cycle: &c [*c]\n")
    elif kind == "merge":
        lines.append("<<: {name: merged, colour: red}\n")
    elif kind == "long_scalar":
        lines.append("name: " + "x" * (arg % 4000) + "\n")
    elif kind == "bigint":
        lines[i] = f"{head}: {'9' * (1 + arg % 5000)}\n"
    elif kind == "tag":
        lines[i] = f"{head}: {TAGS[arg % len(TAGS)]}\n"
    elif kind == "multi_doc":
        lines.append("---\nname: second\n")
    return "".join(lines)


def render(recipe, overrides: dict | None = None) -> bytes:
    """The problem file of a recipe: (base, ops), each op ("set", path, value),
    ("drop", path), ("scale", path, factor), ("nest", path, depth, kind) or ("text", kind,
    arg). ``overrides`` (top
    keys) apply after the key ops, text ops last, to the YAML the others produce."""
    base, ops = recipe
    data = copy.deepcopy(BASES[base])
    for op in ops:
        if op[0] == "set":
            _set(data, op[1], copy.deepcopy(op[2]))
        elif op[0] == "drop":
            _drop(data, op[1])
        elif op[0] == "scale":
            _scale(data, op[1], op[2])
        elif op[0] == "nest":
            _set(data, op[1], _nested(op[2], op[3]))
    data.update(overrides or {})
    text = yaml.safe_dump(data, allow_unicode=True, sort_keys=False)
    for op in ops:
        if op[0] == "text":
            text = _text_op(text, op[1], op[2])
    return text.encode("utf-8", "surrogateescape")


values = st.one_of(st.sampled_from(HOSTILE), st.floats(), st.integers(-2**80, 2**80),
                   st.text(max_size=30), st.lists(st.floats(), max_size=3))
ops = st.one_of(
    st.tuples(st.just("set"), st.sampled_from(PATHS), values),
    st.tuples(st.just("drop"), st.sampled_from(PATHS)),
    # plausible values too, so that many files reach the analysis (designs that do not
    # assemble, toggles, extreme but accepted proportions)
    st.tuples(st.just("scale"), st.sampled_from(NUMBER_PATHS), st.one_of(
        st.sampled_from([0.5, 0.999999, 1.000001, 2, 1e-8, 1e8, -1, 0]),
        st.floats(0.01, 100))),
    st.tuples(st.just("scale"), st.sampled_from(NUMBER_PATHS), st.floats(0.3, 3)),
    st.tuples(st.just("nest"), st.sampled_from(PATHS), st.integers(1, 40),
              st.sampled_from(["list", "map"])),
    st.tuples(st.just("text"), st.sampled_from(TEXT_OPS), st.integers(0, 10**6)))
recipes = st.tuples(st.sampled_from(sorted(BASES)), st.lists(ops, max_size=3).map(tuple))
#: for solve: hostile values only (a plausible value such as 64 phases is a long solve, not
#: a bug), and never the solver: section that keeps the run small
solve_ops = st.one_of(
    st.tuples(st.just("set"), st.sampled_from([p for p in PATHS if not p.startswith("solver")]),
              st.sampled_from([v for v in HOSTILE if not isinstance(v, (int, float))
                               or isinstance(v, bool) or not 2 <= abs(v) <= 1e6])),
    st.tuples(st.just("text"), st.sampled_from(TEXT_OPS), st.integers(0, 10**6)))
solve_recipes = st.tuples(st.sampled_from(SOLVE_BASES), st.lists(solve_ops, max_size=2)
                          .map(tuple))


# --------------------------------------------------------------------------- checks
class Hang(BaseException):
    """An in-process run past its time limit (a BaseException: the CLI must not catch it)."""


def strict_json(text: str):
    def refuse(constant):
        raise ValueError(f"not JSON: {constant}")
    return json.loads(text, parse_constant=refuse)


def check_outcome(code, out, err, *, json_expected: bool, quiet: bool = False):
    """The contract's promises for any file; ``quiet``: nothing but the failure line may be
    on stderr (in-process, where pytest takes the warnings)."""
    assert code in (0, 1, 2), (code, err)
    for bad in ("Traceback", "internal error", "out of memory"):
        assert bad not in err, err
    # a valid file's likely unit mistake is one warning line, besides any failure's line
    warned = [line for line in err.splitlines(True) if line.startswith("optdesign: warning: ")]
    assert len(warned) <= 1, err
    err = "".join(line for line in err.splitlines(True) if line not in warned)
    if code == 2:
        assert err.count("\n") == 1 and err.startswith("optdesign: "), err
        assert len(err) <= 1001
    if quiet:
        assert err.count("\n") <= 1, err
    if json_expected and out.strip():
        strict_json(out)
    if json_expected and code == 0:
        assert strict_json(out)


def analyze_in_process(path: Path):
    def alarm(*_):
        raise Hang(f"analyze took more than {ANALYZE_LIMIT_S} s")
    previous = signal.signal(signal.SIGALRM, alarm)
    signal.alarm(ANALYZE_LIMIT_S)
    out, err = io.StringIO(), io.StringIO()
    try:
        with redirect_stdout(out), redirect_stderr(err):
            code = main(["analyze", str(path), "--json"])
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    return code, out.getvalue(), err.getvalue()


#: examples of the in-process analyze fuzzer; OPTDESIGN_FUZZ_EXAMPLES=5000 for a longer hunt
ANALYZE_EXAMPLES = int(os.environ.get("OPTDESIGN_FUZZ_EXAMPLES", 400))
#: examples of each subprocess fuzzer (solve, curves: a few seconds each)
SUBPROCESS_EXAMPLES = int(os.environ.get("OPTDESIGN_FUZZ_SUBPROCESS_EXAMPLES", 4))
FUZZ = settings(deadline=None, max_examples=ANALYZE_EXAMPLES, print_blob=True,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                       HealthCheck.filter_too_much])


# --------------------------------------------------------------------------- analyze
@FUZZ
@given(recipe=recipes)
# hostile files that once ended in a traceback, a hang, a wrong δ or invalid JSON
@example(recipe=("sharkov2022", (("set", "input_speed", 1e-320),)))
@example(recipe=("sharkov2022", (("set", "design.l1", 1e-320),)))
@example(recipe=("sharkov2022", (("set", "design.l1", 1e-15),)))
@example(recipe=("sharkov2022", (("scale", "design.l3", 0.3),)))      # exit 1, assembles: false
@example(recipe=("sharkov2022", (("set", "regulation.eccentricity", [1.0, 1e-320]),)))
@example(recipe=("sharkov2022", (("set", "input_speed", 10**400),)))
@example(recipe=("driveline", (("set", "constraints.max_speed_fraction_of_critical", 10**30),)))
@example(recipe=("driveline", (("set", "constraints", 10**400), ("scale", "constraints", 1.0))))
@example(recipe=("sharkov2022", (("set", "design.phases", {"lower": 4, "upper": 1e9}),)))
@example(recipe=("sharkov2022", (("set", "design.phases", 1000),)))
@example(recipe=("sharkov2022", (("set", "design.phases", 1e30),)))
@example(recipe=("sharkov2022", (("set", "solver.samples", 1e30),)))
@example(recipe=("sharkov2022", (("set", "solver.max_iter", 2147483648),)))
@example(recipe=("sharkov2022", (("set", "name", "x" * 300),)))
@example(recipe=("sharkov2022", (("set", "name", "a\0b"),)))
@example(recipe=("sharkov2022", (("set", "name", ""),)))
@example(recipe=("driveline", (("set", "driveline.wall_mm", 1e-320),)))
@example(recipe=("driveline", (("set", "driveline.wall_mm", 1e-30),)))
@example(recipe=("driveline", (("set", "driveline.density_kg_m3", 1e-320),)))
@example(recipe=("driveline", (("set", "driveline.outer_diameter_mm", 1e100),)))
@example(recipe=("sharkov2022", (("text", "deep_list", 4990),)))
@example(recipe=("sharkov2022", (("text", "deep_map", 50),)))
@example(recipe=("sharkov2022", (("text", "alias_bomb", 4),)))
@example(recipe=("sharkov2022", (("text", "dup_line", 3),)))
@example(recipe=("sharkov2022", (("text", "nul", 40),)))
@example(recipe=("sharkov2022", (("text", "tag", 3),)))
@example(recipe=("sharkov2022", (("text", "anchor_cycle", 0),)))
def test_analyze_survives_hostile_files(tmp_path_factory, recipe):
    path = tmp_path_factory.mktemp("fuzz") / "p.yaml"
    path.write_bytes(render(recipe))
    code, out, err = analyze_in_process(path)
    event(f"exit {code}")               # pytest --hypothesis-show-statistics
    check_outcome(code, out, err, json_expected=True, quiet=True)


# --------------------------------------------------------------------------- solve, curves
def _subprocess(argv, cwd):
    proc = subprocess.run([sys.executable, "-m", "optdesign", *argv], cwd=cwd,
                          capture_output=True, text=True, timeout=SUBPROCESS_LIMIT_S,
                          env=os.environ | {"PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"})
    return proc.returncode, proc.stdout, proc.stderr


def _written_json_is_valid(folder: Path):
    for path in folder.rglob("*.json"):
        strict_json(path.read_text())


def _stays_inside(work: Path):
    """What the command wrote is under work/results/: folders one level down, each with at
    most its lock file beside it (optdesign.outputs.folder)."""
    results = work / "results"
    if results.exists():
        folders = {c.name for c in results.iterdir() if c.is_dir()}
        for child in results.iterdir():
            assert child.name in folders or (
                child.name.startswith(".") and child.name.endswith(".lock")
                and child.name[1:-len(".lock")] in folders), child
        assert not any(name.startswith(".") for name in folders), folders


@settings(FUZZ, max_examples=SUBPROCESS_EXAMPLES)
@given(recipe=solve_recipes)
@example(recipe=("sharkov2022_disc", (("set", "name", "../../../escaped"),)))
def test_solve_survives_hostile_files(tmp_path_factory, recipe):
    work = tmp_path_factory.mktemp("solve")
    (work / "p.yaml").write_bytes(render(recipe, {"solver": SMALL_SOLVER}))
    code, out, err = _subprocess(["solve", "p.yaml", "--no-plots", "--json"], work)
    event(f"exit {code}")
    check_outcome(code, out, err, json_expected=True)
    _written_json_is_valid(work)
    _stays_inside(work)
    assert sorted(p.name for p in work.iterdir()) in (["p.yaml"], ["p.yaml", "results"])


@settings(FUZZ, max_examples=SUBPROCESS_EXAMPLES)
@given(recipe=recipes)
@example(recipe=("vergov", (("set", "name", "/etc/passwd"),)))
def test_curves_survives_hostile_files(tmp_path_factory, recipe):
    work = tmp_path_factory.mktemp("curves")
    (work / "p.yaml").write_bytes(render(recipe))
    code, out, err = _subprocess(["curves", "p.yaml", "--samples", "64"], work)
    event(f"exit {code}")
    check_outcome(code, out, err, json_expected=False)
    _stays_inside(work)
    if code == 0:
        assert list((work / "results").glob("*/curves.png"))


def test_the_recipes_cover_the_declared_keys():
    """The fuzzer reaches every section and the solver keys, and its bases are the files."""
    for key in ("solver.max_iter", "driveline.wall_mm", "dynamics.cycles", "pareto.points",
                "design.phases.choices", "design.r1.initial", "regulation.eccentricity"):
        assert key in PATHS
    assert set(BASES) == {p.stem for p in PROBLEMS} and len(BASES) >= 8
    assert "sharkov2022_disc" in SOLVE_BASES

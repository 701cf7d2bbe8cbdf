"""The problem-file reference cannot drift from the loader: docs/problem-file.md, the JSON
Schema and ``optdesign init`` are generated from the declarations the loader checks values
against, and these tests fail when a default, a range or a key differs between them."""
import copy
import math
import re
from dataclasses import replace
from importlib import import_module

import pytest
from jsonschema import Draft202012Validator

from optdesign.cli import main
from optdesign.declarations import REQUIRED
from optdesign.errors import ProblemError
from optdesign.mechanisms import get_mechanism, known
from optdesign.problem.loader import (SECTION_PARSERS, load_problem, problem_from_dict)
from optdesign.problem.keys import constraint_keys, problem_keys, section_keys, walk
from optdesign.problem.schema import problem_schema
from optdesign.problem.yaml_text import parse
from optdesign.problem.reference import REGENERATE, reference_markdown
from optdesign.problem.starter import starter_text
from tests.conftest import ROOT, base_problem

MECHANISMS = known()


# --------------------------------------------------------------------------- the page
def test_the_committed_reference_is_the_generated_one():
    committed = (ROOT / "docs" / "problem-file.md").read_text(encoding="utf-8")
    assert committed == reference_markdown(), \
        f"docs/problem-file.md is stale: regenerate it with `{REGENERATE}`"


def test_the_reference_names_every_key_of_every_mechanism():
    text = reference_markdown()
    for mechanism in MECHANISMS:
        for path, key in walk(problem_keys(mechanism)):
            inside = path.split(".", 1)[-1]            # a row of its section's table
            assert f"`{inside}`" in text or f"`{path}`" in text, path
        assert f"optdesign init --mechanism {mechanism}" in text


# --------------------------------------------------------------------------- declarations
def test_every_mechanism_declares_its_constraint_keys_and_has_a_starter():
    for mechanism in MECHANISMS:
        mech = get_mechanism(mechanism)
        declared = {k.name for k in constraint_keys(mech)}     # raises for an undeclared one
        assert set(mech.constraint_keys) <= declared
        assert set(mech.starter["design"]) == {v.name for v in mech.variables}


def test_every_section_declares_the_keys_its_parser_reads():
    for name, target in SECTION_PARSERS.items():
        module = import_module(target.split(":")[0])
        assert module.DECLARATION.name == name
        assert {k.name for k in module.DECLARATION.keys} == module.KEYS
    dynamics = import_module("optdesign.dynamics.section")
    assert {k.name for k in dynamics.DECLARATION.keys if k.required} == set(dynamics.REQUIRED)


def _complete(mechanism: str) -> dict:
    """The starting file of ``mechanism`` with every commented key given (one '# ' removed):
    every section present, every optional key at its default."""
    return parse(_uncommented(starter_text(mechanism), mechanism), "complete.yaml")


def _uncommented(text: str, mechanism: str) -> str:
    names = {k.name for _, k in walk(problem_keys(mechanism))}
    pattern = re.compile(r"^# ( *)([A-Za-z_]\w*):")
    return "\n".join(pattern.sub(lambda m: f"{m.group(1)}{m.group(2)}:"
                                 if m.group(2) in names else m.group(0), line)
                     for line in text.splitlines()) + "\n"


def _set(data: dict, path: str, value) -> dict:
    data = copy.deepcopy(data)
    *parents, last = path.split(".")
    node = data
    for key in parents:
        node = node[key]
    node[last] = value
    return data


def _reachable(data: dict, path: str) -> bool:
    node = data
    for key in path.split(".")[:-1]:
        node = node.get(key) if isinstance(node, dict) else None
    return isinstance(node, dict)


def _drop(data: dict, path: str) -> dict:
    data = copy.deepcopy(data)
    *parents, last = path.split(".")
    node = data
    for key in parents:
        node = node[key]
    del node[last]
    return data


def _defaulted(mechanism: str):
    """(path, key) of every key with a default value, in the complete file of ``mechanism``."""
    for path, key in walk(problem_keys(mechanism)):
        if key.default not in (None, REQUIRED) and key.kind != "mapping" and \
                path.count(".") >= 1:
            yield path, key


@pytest.mark.parametrize("mechanism", MECHANISMS)
def test_a_declared_default_is_the_loaders_default(mechanism):
    """Leaving a key out and giving it at its declared default load the same problem: the
    loader's default (a dataclass field, a constant of a section) is the declared one."""
    data = _complete(mechanism)
    checked = 0
    for path, key in _defaulted(mechanism):
        given = problem_from_dict(_set(data, path, key.default), where="p.yaml")
        absent = problem_from_dict(_drop(data, path), where="p.yaml")
        assert replace(given, source="") == replace(absent, source=""), path
        checked += 1
    assert checked >= 30


def _ranged(mechanism: str):
    """(path, key, in_list) of every number or integer with a bound (``in_list``: the items
    of a list), outside the driveline, whose parser ties its values to each other (planes
    inside half the length, speeds below the critical one), and the regulation, whose least
    fraction is also tied to the lengths."""
    for path, key in walk(problem_keys(mechanism)):
        if path.startswith(("driveline", "regulation")) or key.condition:
            continue
        if key.kind in ("number", "integer") and (key.lower, key.upper) != (None, None):
            yield path, key, False
        if key.kind == "list" and key.item.kind in ("number", "integer"):
            yield path, key.item, True


def _inside_and_outside(key):
    """Values on each bound that the key admits, and just past each bound."""
    whole = key.kind == "integer"
    inside, outside = [], []
    for bound, is_open, sign in ((key.lower, key.open_lower, -1), (key.upper, key.open_upper, 1)):
        if bound is None:
            continue
        if bound == 0 and is_open:
            inside.append(1e-100)                    # the least positive number a file may hold
        elif not is_open:
            inside.append(int(bound) if whole else bound)
        step = 1 if whole else abs(bound) * 1e-9 or 1e-12
        outside.append(bound if is_open else bound + sign * step)
    return inside, outside


@pytest.mark.parametrize("mechanism", ["fourbar_converter"])
def test_a_declared_range_is_the_loaders_range(mechanism):
    """Every bound the reference states is where the loader starts refusing: the bound itself
    accepted when closed, refused when open, and a step beyond it refused."""
    data = _complete(mechanism)
    checked = 0
    for path, key, in_list in _ranged(mechanism):
        if not _reachable(data, path):
            continue                        # a key of an alternative the file does not use
        inside, outside = _inside_and_outside(key)
        for value in inside:
            problem_from_dict(_set(data, path, [value] if in_list else value), where="p.yaml")
        for value in outside:
            with pytest.raises(ProblemError, match=re.escape(f"p.yaml: {path}")):
                problem_from_dict(_set(data, path, [value] if in_list else value),
                                  where="p.yaml")
        checked += 1
    assert checked >= 25


# --------------------------------------------------------------------------- optdesign init
SMALL_SOLVER = ("solver: {samples: 16, screen: 32, basins: 1, starts: 1, workers: 1, "
                "max_iter: 40}\n")


@pytest.mark.parametrize("mechanism", MECHANISMS)
def test_init_writes_a_file_that_analyze_and_solve_accept(mechanism, tmp_path, capsys):
    path = tmp_path / f"{mechanism}.yaml"
    assert main(["init", "--mechanism", mechanism, "--out", str(path)]) == 0
    assert main(["analyze", str(path)]) == 0
    problem = load_problem(path)
    assert problem.name == mechanism and problem.free_lengths()     # something to optimise
    written = path.read_text()
    path.write_text(written + SMALL_SOLVER)
    code = main(["solve", str(path), "--out", str(tmp_path / "out"), "--no-plots"])
    assert code in (0, 1), capsys.readouterr().err
    # every section uncommented: still valid, and analyze still exits 0
    complete = tmp_path / "complete.yaml"
    complete.write_text(_uncommented(written, mechanism))
    assert set(load_problem(complete).sections) == set(SECTION_PARSERS)
    assert main(["analyze", str(complete)]) == 0


def test_init_refuses_to_overwrite_unless_forced(tmp_path, capsys):
    path = tmp_path / "my.yaml"
    path.write_text("mine\n")
    assert main(["init", "--out", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "exists; init never overwrites a file (--force does)" in err
    assert path.read_text() == "mine\n"
    assert main(["init", "--out", str(path), "--force"]) == 0
    assert "mechanism: fourbar_converter" in path.read_text()


@pytest.mark.parametrize("args, message", [
    (["--mechanism", "cam"], "--mechanism: unknown mechanism 'cam'; known: fourbar_converter"),
    (["--out", "{tmp}/absent/p.yaml"], "the folder"),
    (["--out", "{tmp}"], "is a folder"),
])
def test_init_bad_arguments_exit_2(tmp_path, capsys, args, message):
    args = [a.replace("{tmp}", str(tmp_path)) for a in args]
    assert main(["init", *args]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err


def test_init_without_out_prints_the_file(capsys):
    assert main(["init", "--mechanism", "slotted_lever"]) == 0
    assert "mechanism: slotted_lever" in capsys.readouterr().out


# --------------------------------------------------------------------------- the schema
@pytest.fixture(scope="module")
def validator():
    schema = problem_schema()
    Draft202012Validator.check_schema(schema)
    return Draft202012Validator(schema)


PROBLEM_FILES = sorted(p for p in (ROOT / "problems").glob("*.yaml")
                       if not p.stem.startswith("atlas_"))     # atlas files: docs/atlas.md


@pytest.mark.parametrize("path", PROBLEM_FILES, ids=[p.name for p in PROBLEM_FILES])
def test_every_problem_file_validates(validator, path):
    data = parse(path.read_text(encoding="utf-8"), path.name)
    assert [e.message for e in validator.iter_errors(data)] == []


@pytest.mark.parametrize("mechanism", MECHANISMS)
def test_the_starting_files_validate(validator, mechanism):
    assert [e.message for e in validator.iter_errors(parse(starter_text(mechanism), "s"))] == []
    assert [e.message for e in validator.iter_errors(_complete(mechanism))] == []


@pytest.mark.parametrize("change", [
    lambda d: _set(d, "design.l0", [100, 400]),
    lambda d: _set(d, "colour", "red"),
    lambda d: _set(d, "solver", {"samples": 8}),
    lambda d: _set(d, "constraints.min_transmission_angle_deg", 90),
    lambda d: _set(d, "objective", {"minimize": "-ratio"}),          # max_ripple missing
    lambda d: _set(d, "stroke", "both"),                             # not a four-bar stroke
    lambda d: _drop(d, "design.l3"),
    lambda d: _set(d, "design.phases", {"lower": 4, "upper": 8, "initial": 6}),
])
def test_the_schema_refuses_what_the_loader_refuses(validator, change, write_problem):
    data = change(base_problem())
    assert list(validator.iter_errors(data))
    with pytest.raises(ProblemError):
        load_problem(write_problem(data))


def test_a_key_of_another_mechanism_is_refused_by_the_schema(validator):
    data = parse((ROOT / "problems" / "vergov.yaml").read_text(), "vergov.yaml")
    assert not list(validator.iter_errors(data))
    assert list(validator.iter_errors(_set(data, "constraints.min_pin_radius", 10)))


def test_schema_command_prints_the_schema_and_the_page(capsys):
    assert main(["schema"]) == 0
    import json
    assert json.loads(capsys.readouterr().out) == json.loads(json.dumps(problem_schema()))
    assert main(["schema", "--markdown"]) == 0
    assert capsys.readouterr().out == reference_markdown()


# --------------------------------------------------------------------------- helpful errors
@pytest.mark.parametrize("change, message", [
    ({"design": {"l0": [100, 400]}},
     "p.yaml: design.l0 must be a number or a range {lower, upper, initial} (got a list "
     "[100, 400]); to free it write l0: {lower: 100, upper: 400}"),
    ({"design": {"l2": [400, 100, 225]}},
     "to free it write l2: {lower: 100, upper: 400, initial: 225}"),
    ({"design": {"l3": ["a", "b"]}}, "to free it write l3: {lower: L, upper: U}"),
    ({"design": {"phases": [4, 6]}},
     "p.yaml: design.phases must be an integer, a range {lower, upper} or {choices: [...]} "
     "(got a list [4, 6]); to try each of them write phases: {choices: [4, 6]}"),
    ({"objective": {"minimise": "ripple"}},
     "p.yaml: objective.minimise is not a known key; did you mean minimize? known: "
     "max_ripple, min_ratio, minimize, ripple"),
    ({"design": {"l2": {"min": 100, "upper": 300}}},
     "p.yaml: design.l2.min is not a known key; did you mean lower? known: initial, lower, "
     "upper"),
    ({"regulations": {"eccentricity": [1.0]}},
     "p.yaml: regulations is not a known key; did you mean regulation?"),
    ({"solver": {"sample": 30}}, "p.yaml: solver.sample is not a known key; did you mean "
                                 "samples?"),
    ({"design": {"L2": 225}}, "p.yaml: design.L2 is not a known key; did you mean l2?"),
    ({"constraints": {"min_transmision_angle": 40}},
     "constraints.min_transmision_angle is not a known key; did you mean "
     "min_transmission_angle_deg?"),
])
def test_errors_suggest_the_fix(write_problem, change, message):
    data = base_problem()
    for key, value in change.items():
        if isinstance(value, dict) and key in data and key != "objective":
            data[key] = {**data[key], **value}
        else:
            data[key] = value
    if "L2" in change.get("design", {}):
        del data["design"]["l2"]
    with pytest.raises(ProblemError) as err:
        load_problem(write_problem(data))
    assert message in str(err.value)
    assert "\n" not in str(err.value)


def test_a_key_nothing_resembles_gets_no_suggestion(write_problem):
    with pytest.raises(ProblemError) as err:
        load_problem(write_problem(base_problem(colour="red")))
    assert "did you mean" not in str(err.value)


def test_the_cli_prints_the_suggestion_on_one_line(write_problem, capsys):
    data = base_problem()
    data["design"]["l0"] = [100, 400]
    assert main(["analyze", str(write_problem(data))]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "to free it write l0: {lower: 100, upper: 400}" in err


def test_sections_suggest_too(write_problem):
    data = base_problem()
    data["dynamics"] = {"I1": 0.014, "I2": 0.05, "stifness": 2877, "motor": {"a": 230, "b": 2},
                        "load": 5}
    with pytest.raises(ProblemError, match=r"dynamics\.stifness is not a known key; did you "
                                           r"mean stiffness\?"):
        load_problem(write_problem(data))


def test_section_keys_come_from_the_registered_parsers():
    assert [k.name for k in section_keys()] == list(SECTION_PARSERS)
    assert all(math.isfinite(float(k.default)) for _, k in walk(section_keys())
               if isinstance(k.default, (int, float)) and not isinstance(k.default, bool))


# --------------------------------------------------------------------------- the README
def _readme_section() -> str:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    start = text.index("## Five minutes to a first design")
    return text[start:text.index("\n## ", start + 1)]


def test_the_readme_five_minute_start_runs_as_written(tmp_path, monkeypatch, capsys):
    """Every command of the README's first-design section, in order, in an empty folder, with
    the section's two edits made between init and the rest; the printed summary has the
    lines the section explains."""
    import shlex

    section = _readme_section()
    commands = [line for block in re.findall(r"```sh\n(.*?)```", section, re.S)
                for line in block.splitlines() if line.startswith("optdesign ")]
    edits = re.findall(r"^\| `([^`]+)` \| `([^`]+)` \|$", section, re.M)
    assert [c.split()[1] for c in commands] == ["init", "analyze", "solve"] and len(edits) == 2
    monkeypatch.chdir(tmp_path)
    for command in commands:
        assert main(shlex.split(command)[1:]) == 0, command
        if command.split()[1] == "init":
            path = tmp_path / "my.yaml"
            text = path.read_text()
            for before, after in edits:
                assert before in text
                text = text.replace(before, after)
            path.write_text(text)
    printed = capsys.readouterr().out
    shown = re.search(r"```text\n(.*?)```", section, re.S).group(1).splitlines()
    for line in shown[:4]:                      # status, design, δ and ratio, binding
        prefix = line.split("=")[0].split("(")[0]
        assert any(p.startswith(prefix) for p in printed.splitlines()), prefix
    assert "pin_radius" in printed and "l3 lower bound" in printed
    assert (tmp_path / "results" / "my" / "result.json").is_file()
    # the next edit the section suggests is valid: uncomment constraints, set the pin radius
    text = (tmp_path / "my.yaml").read_text()
    text = text.replace("# constraints:", "constraints:").replace(
        "#   min_pin_radius: 0.0", "  min_pin_radius: 60")
    (tmp_path / "my.yaml").write_text(text)
    assert load_problem(tmp_path / "my.yaml").constraints.min_pin_radius == 60

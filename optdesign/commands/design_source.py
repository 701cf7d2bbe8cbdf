"""The design a command evaluates, and where it came from.

``--design FILE`` takes

* a solve's ``result.json`` (its ``design``);
* a ``design.yaml``: a problem file whose design is fixed, as ``optdesign solve`` writes beside
  ``result.json`` (:func:`design_yaml`);
* a front's ``pareto.csv`` or ``pareto.json`` with ``--point K`` (its K-th point, counted
  from 1 in the CSV's row order) or ``--knee`` (the front's knee, from the ``pareto.json``
  beside the CSV).

Without it a command evaluates the problem file's own design (its free lengths at their
initial values). A design file of another mechanism than the problem's (by its
``mechanism``, or by its lengths), or one that lacks a length, is refused: a design is
taken whole, never completed from the problem file. Every value is checked against the
problem by the loader's rules
(:meth:`optdesign.problem.loader.Problem.with_design`); any fault is a one-line
:class:`~optdesign.errors.UsageError` naming the option and the file (exit 2).
"""
from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import dataclass
from pathlib import Path

from optdesign.errors import ProblemError, UsageError, shown

#: the front's files whose points --point and --knee pick from
FRONT_SUFFIXES = (".csv",)
PROBLEM_SUFFIXES = (".yaml", ".yml")
#: design.yaml's name: the problem's, so marked (within the loader's longest name)
DESIGN_SUFFIX = "_design"


@dataclass(frozen=True)
class ChosenDesign:
    """The design keys' values a command evaluates (None: the problem file's own) and where
    they came from, in words a terminal line and a JSON document print."""

    values: dict | None
    source: str

    def stamped(self, doc: dict) -> dict:
        """A command's JSON document with ``design_source`` added before its stamp
        (``schema_version`` and ``units`` stay last)."""
        stamp = ("schema_version", "units")
        return {k: v for k, v in doc.items() if k not in stamp} | \
            {"design_source": self.source} | {k: doc[k] for k in stamp if k in doc}

    def line(self, problem) -> str:
        """A command's first terminal line: where the design came from, and the crank speed
        in rad/s and rpm."""
        from optdesign.outputs.units import input_speed_text

        return f"design: {self.source}; {input_speed_text(problem.input_speed)}"

    def problem(self, problem):
        """``problem`` with this design fixed (the problem itself for the file's own)."""
        if self.values is None:
            return problem
        try:
            return problem.with_design(**self.values)
        except ProblemError as exc:
            raise UsageError(f"--design: {str(exc).split(': ', 1)[-1]}") from None


def add_arguments(parser) -> None:
    """``--design FILE``, ``--point K`` and ``--knee`` of a command that evaluates a design."""
    parser.add_argument("--design", metavar="FILE",
                        help="evaluate this design instead of the file's own: a solve's "
                             "result.json, a design.yaml, or a front's pareto.csv with "
                             "--point K or --knee")
    parser.add_argument("--point", type=int, metavar="K",
                        help="with --design pareto.csv: its K-th point (from 1, in the "
                             "CSV's row order)")
    parser.add_argument("--knee", action="store_true",
                        help="with --design pareto.csv: the front's knee")


def loaded(args, one_count: bool = True):
    """(the problem file ``args.problem`` with the design ``args`` names fixed, that
    :class:`ChosenDesign`): what every command that evaluates a design starts from."""
    from optdesign.problem.loader import load_problem

    problem = load_problem(args.problem)
    chosen = chosen_design(args, problem, one_count)
    return chosen.problem(problem), chosen


def checked_eccentricity(value: float) -> float:
    """``--eccentricity``, a fraction of the regulating length the loader admits
    (UsageError otherwise)."""
    from optdesign.problem.loader import MIN_ECCENTRICITY

    if not MIN_ECCENTRICITY <= value <= 1:
        raise UsageError(f"--eccentricity must lie in [{MIN_ECCENTRICITY:g}, 1] (got "
                         f"{value:g})")
    return value


def chosen_design(args, problem, one_count: bool = True) -> ChosenDesign:
    """The design ``args`` names for ``problem`` (see the module's docstring). With
    ``one_count``, the file's own design must fix its count."""
    point, knee = getattr(args, "point", None), getattr(args, "knee", False)
    if (point is not None or knee) and args.design is None:
        raise UsageError(f"--{'point' if point is not None else 'knee'} picks a point of "
                         f"a front: give the front with --design pareto.csv")
    if point is not None and knee:
        raise UsageError("--point and --knee each pick a point: give one")
    if args.design is None:
        count = problem.model.count_variable
        if one_count and len(problem.counts()) > 1:
            raise UsageError(f"{problem.source}: design.{count} is free; give a solved design "
                             f"with --design FILE (a result.json or a design.yaml)")
        return ChosenDesign(None, "the file's initial design (free lengths at their initial "
                                  "values; --design FILE evaluates a solved one)"
                            if problem.free_lengths() else "the file's design")
    return design_from_file(args.design, problem, point, knee)


def design_from_file(name: str, problem, point: int | None = None,
                     knee: bool = False) -> ChosenDesign:
    """The design file ``name`` holds (a result.json, a design.yaml, or a front with
    ``point`` or ``knee``), checked against ``problem``."""
    path = Path(name)
    where = f"--design {shown(name)}"
    suffix = path.suffix.lower()
    if suffix in PROBLEM_SUFFIXES:
        if point is not None or knee:
            raise UsageError(f"{where}: --point and --knee pick a point of a front "
                             f"(pareto.csv), not of a problem file")
        values, source = _from_problem_file(path, problem, where), f"the design of {path}"
        return ChosenDesign(_checked(values, problem, where), source)
    elif suffix in FRONT_SUFFIXES or (suffix == ".json" and (point is not None or knee)):
        if point is None and not knee:
            raise UsageError(f"{where}: a front holds many designs: pick one with --point K "
                             f"or --knee")
        values, source = _from_front(path, problem, where, point)
        what = "the knee" if point is None else f"point {point}"
    else:
        values, source = _from_result(path, problem, where)
        what = "its design"
    return ChosenDesign(_whole(_checked(_of_the_mechanism(values, problem, where, what),
                                        problem, where), problem, where, what), source)


def file_text(path: Path, where: str) -> str:
    """The file's text, a regular file of at most 1 MiB (never /dev/zero or a FIFO)."""
    from optdesign.problem.yaml_text import read_text

    try:
        return read_text(path)
    except ProblemError as exc:
        raise UsageError(f"{where}: {str(exc).split(': ', 1)[-1]}") from None


def read_json(path: Path, where: str):
    """The JSON document of a regular file of at most 1 MiB (UsageError naming ``where``)."""
    text = file_text(path, where)
    try:
        return json.loads(text)
    except (ValueError, RecursionError):
        raise UsageError(f"{where}: is not JSON") from None


def _from_result(path: Path, problem, where: str) -> tuple[dict, str]:
    """A solve's result.json (or any JSON with a ``design`` object)."""
    data = read_json(path, where)
    design = data.get("design") if isinstance(data, dict) else None
    if not isinstance(design, dict):
        raise UsageError(f"{where}: has no design object (a solve that found none writes "
                         f"design: null)")
    _same_mechanism(data.get("mechanism"), problem, where, "its design")
    status = data.get("status")
    what = "the optimum" if status == "optimal" else "the design"
    return design, f"{what} of {path}"


def _from_problem_file(path: Path, problem, where: str) -> dict:
    """A design.yaml: a problem file of the same mechanism whose every design key is fixed."""
    from optdesign.problem.loader import load_problem

    try:
        other = load_problem(path)
    except ProblemError as exc:
        raise UsageError(f"{where}: {exc}") from None
    _same_mechanism(other.mechanism, problem, where, "its design")
    free = [k for k, v in other.design.items() if v.is_free]
    if free:
        raise UsageError(f"{where}: design.{free[0]} is not fixed (a design file fixes every "
                         f"design key, as solve's design.yaml does)")
    return {k: v.value for k, v in other.design.items()}


def _from_front(path: Path, problem, where: str, point: int | None) -> tuple[dict, str]:
    """The K-th point of a front's pareto.csv (or pareto.json), or its knee."""
    if point is None:
        front = path if path.suffix.lower() == ".json" else path.with_name("pareto.json")
        data = read_json(front, f"--knee: {shown(str(front))}")
        knee = data.get("knee") if isinstance(data, dict) else None
        if not isinstance(knee, dict):
            raise UsageError(f"--knee: {shown(str(front))} has no knee (a front without a "
                             f"verified point has none)")
        return _design_of(knee, problem), (f"the knee of the front {path} (δ = "
                                           f"{_number(knee.get('delta'))}, ratio = "
                                           f"{_number(knee.get('ratio'))})")
    if path.suffix.lower() == ".json":
        data = read_json(path, where)
        rows = data.get("points") if isinstance(data, dict) else None
        rows = rows if isinstance(rows, list) else []
    else:
        rows = list(csv.DictReader(io.StringIO(file_text(path, where))))
    if not 1 <= point <= len(rows):
        raise UsageError(f"--point must lie in [1, {len(rows)}], the points of {shown(str(path))} "
                         f"(got {point})")
    row = rows[point - 1]
    if not isinstance(row, dict) or row.get("status") != "optimal":
        status = row.get("status") if isinstance(row, dict) else None
        why = (": verified, but a design of its count beats it on its own ε-problem"
               if status == "local" else "")
        raise UsageError(f"--point {point}: that point of {shown(str(path))} is not an "
                         f"optimal design of the front (status {shown(status)}{why})")
    return _design_of(row, problem), (f"point {point} of the front {path} (δ = "
                                      f"{_number(row.get('delta'))}, ratio = "
                                      f"{_number(row.get('ratio'))})")


def _design_of(record: dict, problem) -> dict:
    """The design keys of a front's record: the lengths (of any mechanism: a front of
    another is named so by :func:`_of_the_mechanism`) and the count (by the mechanism's
    name, or the generic ``count``)."""
    from optdesign.mechanisms import get_mechanism, known

    model = problem.model
    lengths = {k for m in known() for k in get_mechanism(m).lengths}
    out = {k: v for k, v in record.items() if k in lengths and v not in (None, "")}
    for name in (model.count_variable, "count", "phases"):
        if record.get(name) not in (None, ""):
            out[model.count_variable] = record[name]
            break
    return out


def _number(value) -> str:
    try:
        return f"{float(value):.6g}"
    except (TypeError, ValueError):
        return "?"


def _same_mechanism(mechanism, problem, where: str, what: str) -> None:
    if isinstance(mechanism, str) and mechanism != problem.mechanism:
        name = mechanism if mechanism.isidentifier() and len(mechanism) <= 40 else \
            shown(mechanism, 40)
        raise UsageError(f"{where}: {what} is a {name} design; {problem.source} is a "
                         f"{problem.mechanism}")


def _of_the_mechanism(design: dict, problem, where: str, what: str) -> dict:
    """``design`` when it can be the problem's mechanism's; UsageError naming both
    mechanisms when its lengths are every length of another mechanism and not the
    problem's (a pulse reducer's front given to a four-bar's problem)."""
    from optdesign.mechanisms import get_mechanism, known

    present = {k for k, v in design.items() if v not in (None, "")}
    if set(problem.model.lengths) <= present:
        return design
    for other in known():
        if other != problem.mechanism and set(get_mechanism(other).lengths) <= present:
            _same_mechanism(other, problem, where, what)
    return design


def _whole(values: dict, problem, where: str, what: str) -> dict:
    """``values`` when they name every length of the problem's mechanism: a design is
    taken whole or not at all, never completed from the problem file's own values (which
    the words "point 3 of the front" would then misname)."""
    missing = [k for k in problem.model.lengths if k not in values]
    if missing:
        raise UsageError(f"{where}: {what} has no {missing[0]} (a {problem.mechanism} design "
                         f"names every length: {', '.join(problem.model.lengths)}; none is "
                         f"taken from {problem.source})")
    return values


def _checked(design: dict, problem, where: str) -> dict:
    """``design`` checked against the problem: every key a design key of its mechanism,
    every value a positive number (a CSV's text read as one), the count a whole number the
    problem admits."""
    values = {}
    for key, value in design.items():
        if key not in problem.design:
            name = key if isinstance(key, str) and key.isprintable() and len(key) <= 40 \
                else shown(key, 40)
            raise UsageError(f"{where}: design.{name} is not a design key of "
                             f"{problem.mechanism}")
        if isinstance(value, str):
            try:
                value = float(value)
            except ValueError:
                pass
        elif isinstance(value, int) and not isinstance(value, bool):
            try:
                value = float(value)
            except OverflowError:           # JSON's integers have no bound; floats do
                raise UsageError(f"{where}: design.{key} must be a positive number (got an "
                                 f"integer of {value.bit_length()} bits)") from None
        if isinstance(value, bool) or not isinstance(value, (int, float)) or \
                not math.isfinite(value) or value <= 0:
            raise UsageError(f"{where}: design.{key} must be a positive number "
                             f"(got {shown(value)})")
        values[key] = float(value)
    count = problem.model.count_variable
    if count not in values and len(problem.counts()) > 1:
        raise UsageError(f"{where}: design.{count} is missing")
    if count in values:
        if values[count] != int(values[count]) or int(values[count]) not in problem.counts():
            raise UsageError(f"{where}: design.{count} must be a whole number the problem "
                             f"admits ({problem.counts_text()}; got {values[count]:g})")
        values[count] = int(values[count])
    return values


def design_yaml(source_path, result) -> str | None:
    """The text of design.yaml: the problem file at ``source_path`` with the design of
    ``result`` (a SolveResult) fixed, named ``NAME_design``, runnable as it is; None without
    a design or a readable source."""
    from optdesign.problem.yaml_text import parse, read_text

    if not result.design or source_path is None:
        return None
    try:
        data = parse(read_text(Path(source_path)), str(source_path))
    except ProblemError:
        return None
    if not isinstance(data, dict):
        return None
    header = (f"# {result.name}, its optimum fixed: the problem file {Path(source_path).name} "
              f"with the design of result.json\n"
              f"# (δ = {result.delta:.6g}, ratio = {result.ratio:.6g}). Runnable as it is, "
              f"e.g. optdesign analyze design.yaml;\n"
              f"# or give it to any command that evaluates a design: --design design.yaml.\n")
    return header + design_text(data, result)


def design_text(data: dict, result) -> str:
    """The problem file's mapping ``data`` with the design of ``result`` (``.name``,
    ``.mechanism``, ``.design``) fixed and named ``NAME_design``, as YAML: what
    ``--design`` and every command read."""
    import yaml

    from optdesign.problem.loader import MAX_NAME_CHARS

    data = dict(data)
    data["name"] = f"{result.name[:MAX_NAME_CHARS - len(DESIGN_SUFFIX)]}{DESIGN_SUFFIX}"
    data["design"] = {k: (int(v) if float(v).is_integer() and k not in _lengths(result)
                          else float(v)) for k, v in result.design.items()}
    objective = data.get("objective")
    if isinstance(objective, dict) and objective.get("minimize") == "phases":
        # the least count is fixed now: its least δ, the count's own objective, stays
        data["objective"] = dict(objective) | {"minimize": "ripple"}
    return yaml.safe_dump(data, sort_keys=False, allow_unicode=True)


def _lengths(result) -> set[str]:
    from optdesign.mechanisms import get_mechanism

    return set(get_mechanism(result.mechanism).lengths)

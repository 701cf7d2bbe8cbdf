"""The explorer's state: one problem, the design on screen, and what a designer does to them.

A :class:`Session` holds the problem file's mapping (to move a bound in it and load it again
by the loader's rules, :mod:`optdesign.explorer.bounds`), the problem loaded from it, the
design on screen (every design key) and the drawn eccentricity. Its actions are what the
page's controls call: set a length or the count (checked by the loader's rules and the
file's ranges), move a bound, re-optimise from the design on screen
(:mod:`optdesign.explorer.reoptimise`), load a design file or a front's point
(:mod:`optdesign.commands.design_source`, as ``--design`` reads them), save the design as a
``design.yaml`` (written atomically, as ``solve`` writes its own). It knows nothing of the
page: the browser and the notebook share it.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path

from optdesign.errors import ProblemError, UsageError, shown
from optdesign.explorer.bounds import Bound, bounds_of, moved
from optdesign.explorer.reoptimise import Reoptimised, Reoptimiser
from optdesign.explorer.snapshot import Snapshot, snapshot


class Session:
    """One problem explored (see the module's text).

    Parameters
    ----------
    problem : Problem
        The problem loaded from ``data``.
    data : dict
        The problem file's mapping (what its YAML holds).
    values : dict, optional
        The design to start from (design keys); the file's own by default.
    source : str
        Where the starting design came from, in words.
    """

    def __init__(self, problem, data: dict, values: Mapping | None = None,
                 source: str = "the file's design"):
        self.problem = problem
        self.data = data
        self.values = self._whole(values)
        self.source = source
        self.eccentricity = 1.0
        self.reoptimiser = Reoptimiser()
        #: the last re-optimisation (its binding constraints shown beside the figures)
        self.last: Reoptimised | None = None

    # ----------------------------------------------------------------- opening
    @classmethod
    def open(cls, problem, design=None, point: int | None = None) -> "Session":
        """A session on ``problem`` (a path, a mapping with the file's keys, or a Problem),
        starting from ``design``: None (the file's own), a mapping of design keys, or a path
        to a result.json, a design.yaml or a front's pareto.csv (with ``point``). Every value
        is checked by the loader's rules; a fault raises a
        :class:`~optdesign.errors.ProblemError` or :class:`~optdesign.errors.UsageError`
        naming the file and key.

        A Problem keeps its file's name only, not the file's mapping the explorer moves
        bounds in: its file is read when found from here and it loads to the same problem,
        else the mapping is written anew from the Problem (:func:`mapping_of`)."""
        from optdesign.problem.loader import Problem, load_problem, problem_from_dict
        from optdesign.problem.yaml_text import parse, read_text

        if isinstance(problem, Problem):
            data = _file_of(problem)
            if data is None:
                data = mapping_of(problem)
            loaded = problem            # each of the two has read ``data`` back to it
        elif isinstance(problem, Mapping):
            data = dict(problem)
            loaded = problem_from_dict(data, where="<dict>")
        elif isinstance(problem, (str, Path)):
            loaded = load_problem(problem)
            data = parse(read_text(Path(problem)), str(problem))
        else:
            raise TypeError(f"a problem is a path, a mapping or a Problem (got "
                            f"{type(problem).__name__})")
        session = cls(loaded, data)
        if design is not None:
            session.load(design, point)
        return session

    def fork(self) -> "Session":
        """A session of its own in the same state (a second page of one server), sharing
        the built NLPs."""
        other = Session(self.problem, self.data, self.values, self.source)
        other.eccentricity = self.eccentricity
        other.reoptimiser = self.reoptimiser
        return other

    def load(self, design, point: int | None = None, knee: bool = False) -> str:
        """Put ``design`` on screen (see :meth:`open`; ``knee``: a front's knee); returns
        where it came from."""
        if isinstance(design, Mapping):
            values, source = self.problem.checked_values(design), "the design given"
        else:
            from optdesign.commands.design_source import design_from_file

            if not isinstance(design, (str, Path)):
                raise TypeError(f"a design is a mapping or a path (got "
                                f"{type(design).__name__})")
            chosen = design_from_file(str(design), self.problem, point, knee)
            values, source = chosen.values, chosen.source
        self._in_box(values)
        self.values = self._whole(values)
        self.source = source
        return source

    def _whole(self, values: Mapping | None) -> dict:
        """Every design key: ``values`` over the file's own (the count one it admits)."""
        out = dict(self.problem.start_values())
        key = self.problem.model.count_variable
        admissible = self.problem.counts()
        if out[key] not in admissible:
            out[key] = admissible[len(admissible) // 2]
        out |= dict(values or {})
        out[key] = int(out[key])
        return out

    def _in_box(self, values: Mapping) -> None:
        """UsageError when a free length lies outside the file's range or the count is not
        one it admits (a slider cannot show it)."""
        for k in self.problem.free_lengths():
            if k in values:
                v = self.problem.design[k]
                if not v.lower <= values[k] <= v.upper:
                    raise UsageError(f"{self.problem.source}: design.{k} = {values[k]:g} lies "
                                     f"outside the file's range [{v.lower:g}, {v.upper:g}]")
        key = self.problem.model.count_variable
        if key in values and int(values[key]) not in self.problem.counts():
            raise UsageError(f"{self.problem.source}: design.{key} = {values[key]:g} is not "
                             f"a count the file admits")

    # ----------------------------------------------------------------- controls
    def lengths(self) -> list[tuple[str, float, float]]:
        """(name, lower, upper) of every free length: one slider each."""
        return [(k, self.problem.design[k].lower, self.problem.design[k].upper)
                for k in self.problem.free_lengths()]

    def counts(self) -> list[int]:
        return self.problem.counts()

    def bounds(self) -> list[Bound]:
        return bounds_of(self.problem)

    def set(self, key: str, value) -> None:
        """Set one design key (a length or the count), checked by the loader's rules and
        the file's range."""
        checked = self.problem.checked_values({key: value})
        self._in_box(checked)
        self.values = self._whole(self.values | checked)

    def set_eccentricity(self, value: float) -> None:
        """The eccentricity the linkage and its speeds are drawn at, in (0, 1]."""
        from optdesign.problem.loader import MIN_ECCENTRICITY

        value = float(value)
        if not (math.isfinite(value) and MIN_ECCENTRICITY <= value <= 1):
            raise UsageError(f"the eccentricity must lie in [{MIN_ECCENTRICITY:g}, 1] (got "
                             f"{shown(value)})")
        self.eccentricity = value

    def set_bound(self, key: str, value: float) -> None:
        """Move the bound at the file key ``key`` (:mod:`optdesign.explorer.bounds`)."""
        self.problem, self.data = moved(self.problem, self.data, key, value)

    # ----------------------------------------------------------------- actions
    def evaluate(self) -> Snapshot:
        """The design on screen evaluated exactly (:func:`optdesign.explorer.snapshot.snapshot`)."""
        return snapshot(self.problem, self.values, self.eccentricity)

    def prepare(self) -> None:
        """Build the NLP of the count on screen ahead of the first re-optimisation."""
        self.reoptimiser.prepare(self.problem, self.values)

    def reoptimise(self) -> Reoptimised:
        """IPOPT warm-started from the design on screen; the design moves to where it ends
        when that is a verified optimum."""
        done = self.reoptimiser.reoptimise(self.problem, self.values)
        if done.status == "optimal":
            self.values = self._whole(done.values)
        self.last = done
        return done

    def save(self, path) -> Path:
        """The design on screen as a design.yaml at ``path`` (the file's mapping, its bounds
        as moved, every design key fixed; written atomically); ``optdesign analyze --design``
        and every command read it."""
        from types import SimpleNamespace

        from optdesign.commands.design_source import design_text
        from optdesign.outputs.atomic import atomic_write_text

        shot = self.evaluate()
        record = SimpleNamespace(name=self.problem.name, mechanism=self.problem.mechanism,
                                 design=dict(self.values))
        header = (f"# {self.problem.name}: a design saved by optdesign explore "
                  f"({shot.delta_text}). Runnable as it is,\n"
                  f"# e.g. optdesign analyze design.yaml, or --design design.yaml.\n")
        return atomic_write_text(Path(path), header + design_text(self.data, record))


def _file_of(problem) -> dict | None:
    """The mapping of ``problem``'s file when it is found from here (its ``source``) and
    loads to the same problem (a Problem changed in code does not), else None."""
    from optdesign.problem.loader import load_problem
    from optdesign.problem.yaml_text import parse, read_text

    path = Path(problem.source)
    if not path.is_file():
        return None
    try:
        same = load_problem(path) == problem
    except ProblemError:
        return None
    return parse(read_text(path), str(path)) if same else None


def mapping_of(problem) -> dict:
    """A problem file's mapping that the loader reads back to ``problem`` (every key
    written out, defaults too): the mapping the explorer moves bounds in and saves a design
    with, for a Problem whose file is not at hand. A ProblemError when ``problem`` has
    what a mapping written here cannot hold (a ``pareto:``, ``tolerances:``, ``driveline:``
    or ``dynamics:`` section, a bound held for a front's axis) and its file is not found."""
    from dataclasses import asdict, fields

    from optdesign.problem.loader import Constraints, problem_from_dict, raw_variable

    def unavailable(what: str) -> ProblemError:
        return ProblemError(f"{problem.source}: the explorer moves bounds in the problem "
                            f"file's keys, and this Problem's file is not found from here "
                            f"({what}): give the file's path or its mapping")

    if problem.sections or problem.constraints.extra:
        raise unavailable("its " + ", ".join(f"{k}:" for k in (
            *problem.sections, *problem.constraints.extra)) + " cannot be written anew")
    c = problem.constraints
    constraints = {f.name: getattr(c, f.name) for f in fields(Constraints)
                   if f.name not in ("own", "extra", "bounds", "spelled")}
    constraints |= dict(c.own)
    for b in c.bounds:
        constraints[b.name] = {side: value for side, value in (("lower", b.lower),
                                                                 ("upper", b.upper))
                               if math.isfinite(value)}
        if b.at is not None:
            constraints[b.name]["at"] = b.at
    if not any(b.name == "transmission_angle" for b in c.bounds):
        constraints["min_transmission_angle_deg"] = 0.0       # none held
    if problem.eccentricity_range is not None:
        lower, upper = problem.eccentricity_range
        regulation = {"eccentricity": {"lower": lower, "upper": upper}}
    else:
        regulation = {"eccentricity": list(problem.eccentricities)}
    data = {"name": problem.name, "mechanism": problem.mechanism,
            "input_speed": problem.input_speed, "stroke": problem.stroke,
            "design": {k: raw_variable(v) for k, v in problem.design.items()},
            "options": dict(problem.options), "constraints": constraints,
            "objective": asdict(problem.objective), "regulation": regulation,
            "solver": asdict(problem.solver)}
    try:
        same = problem_from_dict(data, where=problem.source) == problem
    except ProblemError:
        same = False
    if not same:
        raise unavailable("it does not read back from a mapping written anew")
    return data

"""Problem files (docs/contract.md), loaded strictly into frozen dataclasses.

Every error is a :class:`ProblemError` whose one line names the file and the key path and says
what would be right: ``pump.yaml: design.l3.upper must exceed lower (got 20 <= 56)``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from importlib import import_module
from pathlib import Path
from typing import Any, Mapping

from .criteria import OBJECTIVES
from .errors import ProblemError, shown
from .mechanisms import get_mechanism

#: Optional sections parsed by the module that owns them, imported only when present:
#: name -> "module:function(section_dict, where) -> parsed object".
SECTION_PARSERS: dict[str, str] = {
    "driveline": "optdesign.driveline.section:parse_section",
    "dynamics": "optdesign.dynamics.section:parse_section",
    "pareto": "optdesign.pareto.section:parse_section",
}

TOP_KEYS = {"name", "mechanism", "input_speed", "stroke", "design", "options", "constraints",
            "objective", "regulation", "solver"}
RIPPLE_DEFINITIONS = ("midrange", "mean")
HESSIANS = ("exact", "limited-memory")

# Limits of the values a problem file may give (docs/contract.md, "Limits"); those of the
# file itself (size, nesting, aliases) are in optdesign.problem_yaml.
#: every number is finite and, unless zero, of a magnitude in this range: no denormal (whose
#: few significant bits change δ) and no value whose square or cube overflows
NUMBER_MAGNITUDE = (1e-100, 1e100)
MAX_NAME_CHARS = 100            # ``name``: results go to results/NAME/
MAX_TEXT_CHARS = 100            # any other text (choices such as ``stroke``)
MAX_INTEGER = 1_000_000         # a count with no limit of its own
MAX_COUNT = 64                  # phases, sections, freewheels
MAX_ECCENTRICITIES = 16
MIN_ECCENTRICITY = 1e-9         # below it the ratio (∝ e) is lost in rounding
#: least (regulated length × eccentricity) / longest length: _check_regulated_scale
MIN_REGULATED_FRACTION = 1e-9
#: solver keys: (least, most)
SOLVER_INTEGERS = {"samples": (16, 2000), "starts": (1, 1000), "agree": (1, 100),
                   "seed": (0, 2**32 - 1), "max_iter": (1, 100_000), "screen": (1, 65_536),
                   "basins": (1, 64), "workers": (0, 256)}
SMOOTHING_MAX = 1e6


@dataclass(frozen=True)
class Variable:
    """A design key: fixed (``value``) or free within ``lower``..``upper`` (or over ``choices``)."""

    name: str
    value: float | None = None
    lower: float | None = None
    upper: float | None = None
    initial: float | None = None
    choices: tuple[int, ...] | None = None

    @property
    def is_free(self) -> bool:
        return self.value is None

    def start(self) -> float:
        """Fixed value, else the initial guess, else the middle of the bounds."""
        if self.value is not None:
            return self.value
        if self.initial is not None:
            return self.initial
        if self.choices:
            return self.choices[0]
        return 0.5 * (self.lower + self.upper)

    def admissible(self) -> list[int]:
        """The integer values an integer variable may take."""
        if self.value is not None:
            return [int(self.value)]
        if self.choices:
            return list(self.choices)
        return list(range(int(self.lower), int(self.upper) + 1))


@dataclass(frozen=True)
class Constraints:
    """Design constraints; every one is stated as g >= 0 in the NLP."""

    min_transmission_angle_deg: float = 40.0
    min_pin_radius: float = 0.0
    assembly_margin: float = 1e-3       # 1 - cos²μ >= margin at every sample
    grashof: bool = False               # chain 1 a crank-rocker: s + l <= p + q
    extra: Mapping[str, Any] = field(default_factory=dict)   # keys other modules own


@dataclass(frozen=True)
class Objective:
    minimize: str = "ripple"            # ripple | -ratio
    ripple: str = "midrange"            # midrange (paper) | mean (time mean)
    min_ratio: float = 0.0
    max_ripple: float | None = None


@dataclass(frozen=True)
class SolverSettings:
    samples: int = 30                   # crank samples per turn in the NLP (docs/accuracy.md)
    starts: int = 8                     # most IPOPT polishes per phase count
    agree: int = 2                      # infeasible after agree + 1 local-infeasibility verdicts
    screen: int = 512                   # designs screened before IPOPT (Sobol sample)
    basins: int = 2                     # best basins of the screening polished (then lines)
    workers: int = 0                    # processes polishing basins at once (0: every core)
    smoothing: float = 200.0            # log-sum-exp ρ, per unit of ω/ω1
    seed: int = 0
    max_iter: int = 100                 # IPOPT iterations per start
    hessian: str = "limited-memory"     # or exact (CasADi's second derivatives): README
    peak_samples: bool = False          # also bound ω_max at every sample (a safety net)


@dataclass(frozen=True)
class Problem:
    """A loaded problem: what is optimised, independent of how it is solved."""

    name: str
    mechanism: str
    input_speed: float
    stroke: str
    design: Mapping[str, Variable]
    options: Mapping[str, str]
    constraints: Constraints = Constraints()
    objective: Objective = Objective()
    eccentricities: tuple[float, ...] = (1.0,)
    solver: SolverSettings = SolverSettings()
    sections: Mapping[str, Any] = field(default_factory=dict)
    source: str = "<dict>"

    @property
    def model(self):
        return get_mechanism(self.mechanism)

    @property
    def count_variable(self) -> Variable:
        return self.design[self.model.count_variable]

    def counts(self) -> list[int]:
        return self.count_variable.admissible()

    def free_lengths(self) -> list[str]:
        return [k for k in self.model.lengths if self.design[k].is_free]

    def start_values(self) -> dict[str, float]:
        """Every design key at its fixed or initial value (the design ``analyze`` evaluates)."""
        return {k: v.start() for k, v in self.design.items()}

    def with_values(self, values: Mapping[str, float]) -> "Problem":
        """The same problem with every given key fixed at the given value."""
        design = dict(self.design)
        for k, v in values.items():
            design[k] = Variable(k, value=float(v))
        return replace(self, design=design)


    def require_section(self, key: str):
        """The parsed ``key:`` section, or a ProblemError naming the file when it is missing."""
        if key not in self.sections:
            raise ProblemError(f"{self.source}: {key} is required by this command "
                               f"(add a {key}: section)")
        return self.sections[key]


# --------------------------------------------------------------------------- loading
def load_problem(path: str | Path) -> Problem:
    """Read and validate a YAML problem file, within the limits of
    :mod:`optdesign.problem_yaml` (size, nesting, aliases, duplicate keys)."""
    from .problem_yaml import parse, read_text

    path = Path(path)
    where = _printable(path.name) or str(path)
    data = parse(read_text(path), where)
    if data is None:
        raise ProblemError(f"{where}: the file is empty")
    return problem_from_dict(data, where=where, default_name=_default_name(path.stem))


def _printable(text: str) -> str:
    """``text`` with every character that would break a one-line message replaced by '?'."""
    return "".join(c if c.isprintable() else "?" for c in text)


def _default_name(stem: str) -> str:
    """The file's stem as a problem name (a name of at most MAX_NAME_CHARS printable
    characters), for a file without ``name:``."""
    return _printable(stem)[:MAX_NAME_CHARS] or "problem"


def problem_from_dict(data: Any, where: str = "<dict>", default_name: str = "problem") -> Problem:
    """Validate a problem given as a mapping (what a YAML file holds)."""
    r = Reader(where)
    top = r.mapping(data, "")
    r.known_keys(top, "", TOP_KEYS | set(SECTION_PARSERS))
    name = _read_name(r, top.get("name", default_name))
    if "mechanism" not in top:
        raise r.error("mechanism", "is required")
    mechanism_name = r.text(top["mechanism"], "mechanism")
    try:
        mech = get_mechanism(mechanism_name)
    except ProblemError as exc:
        raise r.error("mechanism", str(exc)) from None
    if "input_speed" not in top:
        raise r.error("input_speed", "is required (crank speed ω1, rad/s)")
    input_speed = r.number(top["input_speed"], "input_speed", positive=True)
    stroke = r.text(top.get("stroke", "forward"), "stroke")
    if stroke not in mech.strokes:
        raise r.error("stroke", f"must be one of {', '.join(mech.strokes)} (got {stroke!r})")

    design = _read_design(r, top, mech)
    options = _read_options(r, top.get("options", {}), mech)
    constraints = _read_constraints(r, top.get("constraints", {}), mech)
    objective = _read_objective(r, top.get("objective", {}))
    ecc = _read_regulation(r, top.get("regulation", {}))
    solver = _read_solver(r, top.get("solver", {}))
    sections = {}
    for key, target in SECTION_PARSERS.items():
        if key in top:
            module, func = target.split(":")
            sections[key] = getattr(import_module(module), func)(top[key], r.sub(key))
    for key in constraints.extra:
        owner = EXTRA_CONSTRAINT_SECTIONS.get(key)
        if owner is not None and owner not in sections:
            raise r.error(f"constraints.{key}", f"needs a {owner}: section")
    problem = Problem(name=name, mechanism=mechanism_name, input_speed=input_speed,
                      stroke=stroke, design=design, options=options, constraints=constraints,
                      objective=objective, eccentricities=ecc, solver=solver,
                      sections=sections, source=where)
    for section in sections.values():
        if hasattr(section, "check_problem"):
            section.check_problem(problem)
    _check_regulated_scale(r, problem)
    count = problem.count_variable.admissible()[0]
    try:
        mech.check_values(problem.start_values(), count)
    except ProblemError as exc:
        raise ProblemError(f"{where}: {exc}") from None
    return problem


def _check_regulated_scale(r, problem: Problem) -> None:
    """The regulated length at its smallest (its least value times the least eccentricity)
    must be at least MIN_REGULATED_FRACTION of the longest length at its largest: below it
    the output speeds, O(ratio) against O(1) angles, are lost in rounding (the time mean
    comes out 0 and δ_mean infinite)."""
    mech = problem.model
    reg = mech.regulating_variable

    def least(v):
        return v.value if v.value is not None else v.lower

    def most(v):
        return v.value if v.value is not None else v.upper

    smallest = least(problem.design[reg]) * min(problem.eccentricities)
    longest = max(mech.lengths, key=lambda k: most(problem.design[k]))
    if smallest < MIN_REGULATED_FRACTION * most(problem.design[longest]):
        raise r.error(f"design.{reg}", f"times the least eccentricity ({smallest:g}) must be "
                                       f"at least {MIN_REGULATED_FRACTION:g} of the longest "
                                       f"length, {longest} = {most(problem.design[longest]):g}"
                                       f"; the output speeds would be lost in rounding")


def _read_name(r, value) -> str:
    """Text of 1 to MAX_NAME_CHARS printable characters: it becomes a folder's name
    (results/NAME/, made safe by optdesign.output_checks)."""
    name = r.text(value, "name", limit=MAX_NAME_CHARS)
    if not name.strip():
        raise r.error("name", "must not be empty")
    if not name.isprintable():
        raise r.error("name", f"must hold printable characters only (got {shown(name)})")
    return name


def _read_design(r, top, mech) -> dict[str, Variable]:
    if "design" not in top:
        raise r.error("design", "is required")
    raw = r.mapping(top["design"], "design")
    r.known_keys(raw, "design", {v.name for v in mech.variables})
    design = {}
    for spec in mech.variables:
        key = f"design.{spec.name}"
        if spec.name not in raw:
            raise r.error(key, f"is required ({spec.meaning}, {spec.unit})")
        design[spec.name] = (_read_count if spec.integer else _read_length)(r, raw[spec.name],
                                                                            key, spec)
    return design


def _read_length(r, value, key, spec) -> Variable:
    if not isinstance(value, Mapping):
        return Variable(spec.name, value=r.number(value, key, positive=True))
    entry = r.mapping(value, key)
    r.known_keys(entry, key, {"lower", "upper", "initial"})
    for bound in ("lower", "upper"):
        if bound not in entry:
            raise r.error(f"{key}.{bound}", "is required for a free variable")
    lower = r.number(entry["lower"], f"{key}.lower", positive=True)
    upper = r.number(entry["upper"], f"{key}.upper", positive=True)
    if upper < lower:
        raise r.error(f"{key}.upper", f"must not be below lower (got {upper:g} < {lower:g})")
    initial = None
    if "initial" in entry:
        initial = r.number(entry["initial"], f"{key}.initial", positive=True)
        if not lower <= initial <= upper:
            raise r.error(f"{key}.initial",
                          f"must lie within [{lower:g}, {upper:g}] (got {initial:g})")
    if upper == lower:
        return Variable(spec.name, value=lower)
    return Variable(spec.name, lower=lower, upper=upper, initial=initial)


def _read_count(r, value, key, spec) -> Variable:
    low = int(spec.minimum)
    if not isinstance(value, Mapping):
        return Variable(spec.name, value=float(r.integer(value, key, low, MAX_COUNT)))
    entry = r.mapping(value, key)
    r.known_keys(entry, key, {"lower", "upper", "choices"})
    if "choices" in entry:
        if set(entry) != {"choices"}:
            raise r.error(key, "takes either choices or lower/upper, not both")
        items = entry["choices"]
        if not isinstance(items, list) or not items:
            raise r.error(f"{key}.choices", "must be a non-empty list of integers")
        choices = tuple(sorted({r.integer(c, f"{key}.choices", low, MAX_COUNT)
                                for c in items}))
        return Variable(spec.name, choices=choices)
    for bound in ("lower", "upper"):
        if bound not in entry:
            raise r.error(f"{key}.{bound}", "is required (or give choices)")
    lower = r.integer(entry["lower"], f"{key}.lower", low, MAX_COUNT)
    upper = r.integer(entry["upper"], f"{key}.upper", low, MAX_COUNT)
    if upper < lower:
        raise r.error(f"{key}.upper", f"must not be below lower (got {upper} < {lower})")
    return Variable(spec.name, choices=tuple(range(lower, upper + 1)))


def _read_options(r, raw, mech) -> dict[str, str]:
    raw = r.mapping(raw, "options")
    specs = {o.name: o for o in mech.options}
    r.known_keys(raw, "options", set(specs))
    options = mech.default_options()
    for k, v in raw.items():
        v = r.text(v, f"options.{k}")
        if v not in specs[k].choices:
            raise r.error(f"options.{k}", f"must be one of {', '.join(specs[k].choices)} "
                                          f"(got {v!r})")
        options[k] = v
    return options


#: constraint keys owned by other modules (e.g. the driveline), kept as given in ``extra``.
EXTRA_CONSTRAINT_KEYS: set[str] = {"max_speed_fraction_of_critical"}
#: the section each of those keys needs; the section's object checks the value in its
#: ``check_problem(problem)``.
EXTRA_CONSTRAINT_SECTIONS: dict[str, str] = {"max_speed_fraction_of_critical": "driveline"}


#: constraint keys every mechanism understands; a mechanism declares its own
#: (``Mechanism.constraint_keys``, e.g. the four-bar's pin radius and Grashof)
GENERAL_CONSTRAINT_KEYS = {"min_transmission_angle_deg", "assembly_margin"}


def _read_constraints(r, raw, mech) -> Constraints:
    raw = r.mapping(raw, "constraints")
    own = GENERAL_CONSTRAINT_KEYS | set(mech.constraint_keys)
    r.known_keys(raw, "constraints", own | EXTRA_CONSTRAINT_KEYS)
    kw = {}
    if "min_transmission_angle_deg" in raw:
        mu = r.number(raw["min_transmission_angle_deg"], "constraints.min_transmission_angle_deg")
        if not 0 <= mu < 90:
            raise r.error("constraints.min_transmission_angle_deg",
                          f"must lie in [0, 90) degrees (got {mu:g})")
        kw["min_transmission_angle_deg"] = mu
    if "assembly_margin" in raw:
        m = r.number(raw["assembly_margin"], "constraints.assembly_margin")
        if not 0 <= m < 1:
            raise r.error("constraints.assembly_margin", f"must lie in [0, 1) (got {m:g})")
        kw["assembly_margin"] = m
    kw |= mech.read_constraints({k: raw[k] for k in mech.constraint_keys if k in raw}, r)
    kw["extra"] = {k: v for k, v in raw.items() if k in EXTRA_CONSTRAINT_KEYS}
    return Constraints(**kw)


def _read_objective(r, raw) -> Objective:
    raw = r.mapping(raw, "objective")
    r.known_keys(raw, "objective", {"minimize", "ripple", "min_ratio", "max_ripple"})
    kw = {}
    if "minimize" in raw:
        kw["minimize"] = r.text(raw["minimize"], "objective.minimize")
        if kw["minimize"] not in OBJECTIVES:
            raise r.error("objective.minimize", f"must be one of {', '.join(OBJECTIVES)} "
                                                f"(got {kw['minimize']!r})")
        for key in OBJECTIVES[kw["minimize"]].requires:
            if key not in raw:
                raise r.error(f"objective.{key}",
                              f"is required when minimize is {kw['minimize']}")
    if "ripple" in raw:
        kw["ripple"] = r.text(raw["ripple"], "objective.ripple")
        if kw["ripple"] not in RIPPLE_DEFINITIONS:
            raise r.error("objective.ripple", f"must be one of {', '.join(RIPPLE_DEFINITIONS)}"
                                              f" (got {kw['ripple']!r})")
    if "min_ratio" in raw:
        kw["min_ratio"] = r.number(raw["min_ratio"], "objective.min_ratio")
        if kw["min_ratio"] < 0:
            raise r.error("objective.min_ratio", f"must not be negative (got {kw['min_ratio']:g})")
    if "max_ripple" in raw:
        kw["max_ripple"] = r.number(raw["max_ripple"], "objective.max_ripple", positive=True)
    return Objective(**kw)


def _read_regulation(r, raw) -> tuple[float, ...]:
    raw = r.mapping(raw, "regulation")
    r.known_keys(raw, "regulation", {"eccentricity"})
    values = raw.get("eccentricity", [1.0])
    if not isinstance(values, list) or not values:
        raise r.error("regulation.eccentricity", "must be a non-empty list of fractions in (0, 1]")
    if len(values) > MAX_ECCENTRICITIES:
        raise r.error("regulation.eccentricity", f"must list at most {MAX_ECCENTRICITIES} "
                                                 f"fractions (got {len(values)})")
    out = []
    for v in values:
        e = r.number(v, "regulation.eccentricity", positive=True)
        if e > 1:
            raise r.error("regulation.eccentricity", f"fractions must lie in (0, 1] (got {e:g})")
        if e < MIN_ECCENTRICITY:
            raise r.error("regulation.eccentricity", f"fractions must be at least "
                                                     f"{MIN_ECCENTRICITY:g} (got {e:g})")
        out.append(e)
    return tuple(out)


def _read_solver(r, raw) -> SolverSettings:
    raw = r.mapping(raw, "solver")
    r.known_keys(raw, "solver", {"samples", "starts", "agree", "smoothing", "seed",
                                      "max_iter", "hessian", "peak_samples", "screen",
                                      "basins", "workers"})
    kw = {}
    for key, (low, high) in SOLVER_INTEGERS.items():
        if key in raw:
            kw[key] = r.integer(raw[key], f"solver.{key}", low, high)
    if "smoothing" in raw:
        kw["smoothing"] = r.number(raw["smoothing"], "solver.smoothing", positive=True)
        if kw["smoothing"] > SMOOTHING_MAX:
            raise r.error("solver.smoothing", f"must be at most {SMOOTHING_MAX:g} "
                                              f"(got {kw['smoothing']:g})")
    if "peak_samples" in raw:
        if not isinstance(raw["peak_samples"], bool):
            raise r.error("solver.peak_samples", "must be true or false")
        kw["peak_samples"] = raw["peak_samples"]
    if "hessian" in raw:
        kw["hessian"] = r.text(raw["hessian"], "solver.hessian")
        if kw["hessian"] not in HESSIANS:
            raise r.error("solver.hessian", f"must be one of {', '.join(HESSIANS)} "
                                            f"(got {kw['hessian']!r})")
    return SolverSettings(**kw)


class Reader:
    """Type checks that name the file and the key path of what is wrong."""

    def __init__(self, where: str, prefix: str = ""):
        self.where = where
        self.prefix = prefix

    def sub(self, key: str) -> "Reader":
        return Reader(self.where, f"{self.prefix}{key}.")

    def error(self, key: str, message: str) -> ProblemError:
        key = f"{self.prefix}{key}".rstrip(".")
        return ProblemError(f"{self.where}: {key} {message}" if key else
                            f"{self.where}: {message}")

    def mapping(self, value, key) -> dict:
        if not isinstance(value, Mapping):
            what = "the file" if not key and not self.prefix else key
            raise (self.error(key, f"must be a mapping (got {type(value).__name__})") if
                   what != "the file" else
                   ProblemError(f"{self.where}: must hold a mapping of keys "
                                f"(got {type(value).__name__})"))
        for k in value:
            if not isinstance(k, str):
                raise self.error(key, f"has a key that is not text: {shown(k)}")
        return dict(value)

    def known_keys(self, value: Mapping, key: str, allowed: set[str]) -> None:
        for k in value:
            if k not in allowed:
                k = k if k.isprintable() and len(k) <= 40 else shown(k, 40)
                path = f"{key}.{k}" if key else k
                raise self.error(path, f"is not a known key; known: {', '.join(sorted(allowed))}")

    def number(self, value, key, positive=False) -> float:
        """A finite float; unless zero, its magnitude within NUMBER_MAGNITUDE."""
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.error(key, f"must be a number (got {shown(value)})")
        low, high = NUMBER_MAGNITUDE
        try:
            value = float(value)
        except OverflowError:
            raise self.error(key, f"must be finite and at most {high:g} in magnitude "
                                  f"(got an integer of {value.bit_length()} bits)") from None
        if not math.isfinite(value):
            raise self.error(key, f"must be finite (got {value})")
        if positive and value <= 0:
            raise self.error(key, f"must be positive (got {value:g})")
        if value != 0 and not low <= abs(value) <= high:
            span = f"between {low:g} and {high:g}" if positive else \
                f"0 or of a magnitude between {low:g} and {high:g}"
            raise self.error(key, f"must be {span} (got {value:g})")
        return value

    def integer(self, value, key, minimum, maximum=MAX_INTEGER) -> int:
        """A whole number in [minimum, maximum] (a float such as 4.0 or 1e3 is one)."""
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.error(key, f"must be an integer (got {shown(value)})")
        if isinstance(value, float) and (not math.isfinite(value) or value != int(value)):
            raise self.error(key, f"must be a whole number (got {value})")
        got = f"{value:g}" if isinstance(value, float) else shown(value)
        if value < minimum:
            raise self.error(key, f"must be at least {minimum} (got {got})")
        if value > maximum:
            raise self.error(key, f"must be at most {maximum} (got {got})")
        return int(value)

    def text(self, value, key, limit=MAX_TEXT_CHARS) -> str:
        """Text of at most ``limit`` characters."""
        if not isinstance(value, str):
            raise self.error(key, f"must be text (got {shown(value)})")
        if len(value) > limit:
            raise self.error(key, f"must be at most {limit} characters (got {len(value)})")
        return value

"""Problem files (docs/contract.md), loaded strictly into frozen dataclasses.

Every key is declared once, in the tables below (type, default, unit, range, meaning): the
readers check values against them, and docs/problem-file.md, ``optdesign schema`` and
``optdesign init`` are generated from them (optdesign/problem/keys.py).

Every error is a :class:`ProblemError` whose one line names the file and the key path and says
what would be right: ``pump.yaml: design.l3.upper must exceed lower (got 20 <= 56)``.
"""
from __future__ import annotations

import difflib
import math
from dataclasses import dataclass, field, replace
from importlib import import_module
from pathlib import Path
from typing import Any, Mapping

from optdesign.declarations import Key, REQUIRED, names
from optdesign.envelope.sampled import STROKE_SIGNS
from optdesign.errors import ProblemError, shown
from optdesign.limits import COUNTS
from optdesign.mechanisms import get_mechanism, known
from optdesign.problem.plausibility import warn_implausible
from optdesign.problem.yaml_text import parse, read_text
from optdesign.quantities import known as known_quantities
from optdesign.quantities.bounds import (ALIASES, QuantityBound, generic,
                                         held_apart, read_bound, side_of, with_generic,
                                         with_side, declarations as quantity_declarations)
from optdesign.quantities.criteria import objectives

#: Optional sections parsed by the module that owns them, imported only when present:
#: name -> "module:function(section_dict, where) -> parsed object".
SECTION_PARSERS: dict[str, str] = {
    "driveline": "optdesign.driveline.section:parse_section",
    "dynamics": "optdesign.dynamics.section:parse_section",
    "pareto": "optdesign.fronts.section:parse_section",
    "tolerances": "optdesign.tolerance.section:parse_section",
}

RIPPLE_DEFINITIONS = ("midrange", "mean")
ROBUST_CHOICES = ("none", "worst_case")
HESSIANS = ("exact", "limited-memory")

# Limits of the values a problem file may give (docs/contract.md, "Limits"); those of the
# file itself (size, nesting, aliases) are in optdesign.problem.yaml_text.
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


#: the least transmission angle a problem holds unless its file says otherwise, deg
DEFAULT_MIN_TRANSMISSION_ANGLE_DEG = 40.0


@dataclass(frozen=True)
class Constraints:
    """Design constraints; every one is stated as g >= 0 in the NLP."""

    assembly_margin: float = 1e-3       # 1 - cos²μ >= margin at every sample
    #: the mechanism's own keys (``Mechanism.constraint_declarations``, e.g. the four-bar's
    #: ``min_pin_radius`` and ``grashof``), each at its value or its declared default
    own: Mapping[str, Any] = field(default_factory=dict)
    extra: Mapping[str, Any] = field(default_factory=dict)   # keys other modules own
    #: every bound on a quantity (optdesign.quantities.bounds), one per key, whichever key of
    #: the file gave it: ``constraints: {QUANTITY: {lower, upper, at}}`` or an older key
    #: (``objective.min_ratio`` is the ratio's lower bound, ``objective.max_ripple`` the
    #: ripple's upper one, ``constraints.min_transmission_angle_deg`` the transmission angle's
    #: lower one); :attr:`Problem.quantity_bounds` are those held as bounds on a quantity
    bounds: tuple = (QuantityBound("transmission_angle",
                                   lower=DEFAULT_MIN_TRANSMISSION_ANGLE_DEG),)
    #: the file's own key of each side of a bound that has an older key, by side
    #: (``{"ratio.lower": "constraints.ratio.lower"}``), so that messages name what the user
    #: wrote (optdesign.quantities.bounds.file_key)
    spelled: Mapping[str, str] = field(default_factory=dict, compare=False)

    def __getattr__(self, name: str):
        """A mechanism's own key reads as an attribute too (``constraints.min_pin_radius``)."""
        own = self.__dict__.get("own") or {}
        if name in own:
            return own[name]
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    # the older keys, read from the bounds
    @property
    def min_transmission_angle_deg(self) -> float:
        """The least transmission angle held, deg (0: none)."""
        return max(side_of(self.bounds, "transmission_angle", "lower"), 0.0)

    @property
    def min_ratio(self) -> float:
        """The ratio's floor (0: none)."""
        return max(side_of(self.bounds, "ratio", "lower"), 0.0)

    @property
    def max_ripple(self) -> float | None:
        """The cap on the worst δ, or None."""
        cap = side_of(self.bounds, "ripple", "upper")
        return cap if math.isfinite(cap) else None

    def with_limit(self, name: str, side: str, value: float | None) -> "Constraints":
        """These constraints with the ``side`` of the bound on quantity ``name`` (at its
        default eccentricity) at ``value``; None drops it: ``with_limit("ratio", "lower",
        0.3)`` is ``objective.min_ratio: 0.3``."""
        return replace(self, bounds=with_side(self.bounds, name, side, value))


@dataclass(frozen=True)
class Objective:
    minimize: str = "ripple"            # ripple | -ratio
    ripple: str = "midrange"            # midrange (paper) | mean (time mean)
    robust: str = "none"                # none | worst_case (over the tolerances: box)


@dataclass(frozen=True)
class SolverSettings:
    samples: int = 30                   # crank samples per turn in the NLP (docs/accuracy.md)
    starts: int = 8                     # most IPOPT polishes per phase count
    agree: int = 2                      # infeasible after agree + 1 local-infeasibility verdicts
    screen: int = 512                   # designs screened before IPOPT (Sobol sample)
    basins: int = 2                     # best basins of the screening polished (then lines)
    workers: int = 0                    # cores a solve uses (0: every core)
    smoothing: float = 200.0            # log-sum-exp ρ, per unit of ω/ω1
    seed: int = 0
    max_iter: int = 100                 # IPOPT iterations per start
    hessian: str = "limited-memory"     # or exact (CasADi's second derivatives): README
    peak_samples: bool = False          # also bound ω_max at every sample (a safety net)


# --------------------------------------------------------------------------- declarations
# Every key the loader reads, with its type, default, unit, range and meaning: the loader
# checks values against these tables and docs/problem-file.md, ``optdesign schema`` and
# ``optdesign init`` are generated from them (optdesign/problem/reference.py). Defaults are the
# dataclasses' own (``SolverSettings.samples`` is the field's default), so they cannot differ.
# The design's keys are the mechanism's ``variables``, its options its ``options``.
TOP_DECLARATIONS: tuple[Key, ...] = (
    Key("name", "text", "the problem's name; results go to results/NAME/ (every character "
        "but letters, digits and -_.+ replaced by _)", upper=MAX_NAME_CHARS,
        default_text="the file's stem"),
    Key("mechanism", "choice", "the converting mechanism (docs/mechanisms.md)", default=REQUIRED,
        choices=known),
    Key("input_speed", "number", "crank speed ω1", unit="rad/s", default=REQUIRED, lower=0,
        open_lower=True),
    Key("stroke", "choice", "the stroke whose freewheels drive the output: forward (the rocker "
        "turning with the crank), reverse, or both (a second output shaft); each mechanism "
        "offers its own", default="forward", choices=tuple(STROKE_SIGNS)),
    Key("design", "mapping", "every design key of the mechanism: a number fixes it, a range "
        "frees it (see \"Fixed or free\")", default=REQUIRED),
    Key("options", "mapping", "the mechanism's modelling choices",
        default_text="every option at its default"),
    Key("constraints", "mapping", "the design's constraints", default_text="every default"),
    Key("objective", "mapping", "what the solve minimises", default_text="every default"),
    Key("regulation", "mapping", "the eccentricities at which the ripple is held",
        default_text="full eccentricity only"),
    Key("solver", "mapping", "tuning of the solve", default_text="every default"),
)
TOP_KEYS = names(TOP_DECLARATIONS)

OBJECTIVE_KEYS: tuple[Key, ...] = (
    Key("minimize", "choice", "what the solve minimises: ripple (δ, the worst over the listed "
        "eccentricities), -ratio (the largest ratio with δ at most max_ripple), "
        "-transmission_angle (the largest least transmission angle), phases (the least "
        "admissible count whose least δ is at most max_ripple, that count's least-δ design; "
        "docs/solve.md), or any quantity's worst "
        "over the listed eccentricities, least (NAME: housing_radius, ratio, ...) or largest "
        "(-NAME: -swing, -ripple, ...)",
        default=Objective.minimize, choices=lambda: tuple(objectives())),
    Key("ripple", "choice", "the denominator of δ = (ω_max − ω_min)/ω_mid: midrange, "
        "(ω_max + ω_min)/2 as in the papers, or mean, the time mean of the output speed",
        default=Objective.ripple, choices=RIPPLE_DEFINITIONS),
    Key("min_ratio", "number", "least ratio: time mean of the output speed / ω1, at full "
        "eccentricity", unit="-", default=0.0, lower=0),
    Key("max_ripple", "number", "largest δ allowed", unit="-",
        default=None, default_text="none", lower=0, open_lower=True,
        example=0.5, condition="required with minimize: -ratio or phases"),
    Key("robust", "choice", "none: the nominal design; worst_case: minimise the worst δ over "
        "the tolerances: box, every part of it assembling and meeting every constraint "
        "(with minimize: ripple, listed eccentricities and a tolerances: section; "
        "docs/formulation.md, \"Robust solve\")", default=Objective.robust,
        choices=ROBUST_CHOICES),
)

#: constraint keys every mechanism understands; a mechanism declares its own
#: (``Mechanism.constraint_declarations``, e.g. the four-bar's pin radius and Grashof)
GENERAL_CONSTRAINT_KEYS = {"min_transmission_angle_deg", "assembly_margin"}
#: constraint keys owned by other modules (e.g. the driveline), kept as given in ``extra``.
EXTRA_CONSTRAINT_KEYS: set[str] = {"max_speed_fraction_of_critical"}
#: the section each of those keys needs; the section's object checks the value in its
#: ``check_problem(problem)``.
EXTRA_CONSTRAINT_SECTIONS: dict[str, str] = {"max_speed_fraction_of_critical": "driveline"}

#: the ``constraints:`` keys declared here: the general ones, the sections' extras and a bound
#: per quantity (a mechanism's own are its ``constraint_declarations``)
CONSTRAINT_KEYS: tuple[Key, ...] = (
    Key("min_transmission_angle_deg", "number", "least transmission angle min(μ, 180° − μ) "
        "of every chain over the turn, at every listed eccentricity", unit="deg",
        default=DEFAULT_MIN_TRANSMISSION_ANGLE_DEG, lower=0, upper=90, open_upper=True),
    Key("assembly_margin", "number", "margin of assembly at every sample (1 − cos²μ for a "
        "linkage; 1 − L/XD, 1 − r1/a for the slotted lever and the pulse reducer)", unit="-",
        default=Constraints.assembly_margin, lower=0, upper=1, open_upper=True),
    Key("max_speed_fraction_of_critical", "number", "the cardan shaft's operating speed at "
        "most this fraction of its first critical speed (docs/driveline.md)", unit="-",
        default=None, default_text="none", lower=0, upper=1, open_lower=True, open_upper=True,
        example=0.7, condition="with a driveline: section"),
) + quantity_declarations()

REGULATION_KEYS: tuple[Key, ...] = (
    Key("eccentricity", "either", "the fractions e of the regulated length (l1, L, r1) at "
        "which δ is held: a list (δ computed at each listed e; the solve holds the worst), or "
        "an interval {lower, upper} (δ, the ripple cap, the transmission angle and every "
        "bound on a quantity held at every e in it; docs/formulation.md, \"The whole "
        "regulation range\")", unit="-",
        default=[1.0], alternatives=(
            Key("eccentricity", "list", "the listed fractions", unit="-",
                item=Key("eccentricity", "number", "a fraction of the regulated length",
                         lower=MIN_ECCENTRICITY, upper=1.0),
                min_items=1, max_items=MAX_ECCENTRICITIES),
            Key("eccentricity", "mapping", "the interval of fractions", keys=(
                Key("lower", "number", "the least fraction of the interval", unit="-",
                    default=REQUIRED, lower=MIN_ECCENTRICITY, upper=1.0),
                Key("upper", "number", "the largest fraction of the interval (above lower)",
                    unit="-", default=REQUIRED, lower=MIN_ECCENTRICITY, upper=1.0))))),
)

SOLVER_KEYS: tuple[Key, ...] = (
    Key("samples", "integer", "crank samples per turn in the NLP (docs/accuracy.md)",
        default=SolverSettings.samples, lower=16, upper=COUNTS["nlp_samples"]),
    Key("screen", "integer", "designs screened before IPOPT (a Sobol sample of the box)",
        default=SolverSettings.screen, lower=1, upper=COUNTS["screen"]),
    Key("basins", "integer", "best basins of the screening polished by IPOPT",
        default=SolverSettings.basins, lower=1, upper=COUNTS["basins"]),
    Key("workers", "integer", "cores a solve uses: the screening's threads, the best basins "
        "polished at once and the tolerance analysis's processes (0: every core)",
        default=SolverSettings.workers, lower=0, upper=COUNTS["workers"]),
    Key("starts", "integer", "most IPOPT polishes per phase count",
        default=SolverSettings.starts, lower=1, upper=COUNTS["starts"]),
    Key("agree", "integer", "a count is infeasible after agree + 1 local-infeasibility "
        "verdicts on one constraint", default=SolverSettings.agree, lower=1, upper=COUNTS["agree"]),
    Key("smoothing", "number", "log-sum-exp ρ of the smooth maximum, per unit of ω/ω1",
        default=SolverSettings.smoothing, lower=0, open_lower=True, upper=SMOOTHING_MAX),
    Key("seed", "integer", "seed of the screening's sample", default=SolverSettings.seed,
        lower=0, upper=2**32 - 1),
    Key("max_iter", "integer", "IPOPT iterations per run (three times as many in a box "
        "where a range spans two decades or more)", default=SolverSettings.max_iter,
        lower=1, upper=COUNTS["max_iter"]),
    Key("hessian", "choice", "IPOPT's Hessian: a limited-memory quasi-Newton one, or CasADi's "
        "exact second derivatives (a front's point polished from its neighbour's optimum "
        "runs on the exact one whatever this says)", default=SolverSettings.hessian,
        choices=HESSIANS),
    Key("peak_samples", "bool", "also bound ω_max at every sample (a safety net)",
        default=SolverSettings.peak_samples),
)
#: solver integers: (least, most), from SOLVER_KEYS
SOLVER_INTEGERS = {k.name: (int(k.lower), int(k.upper)) for k in SOLVER_KEYS
                   if k.kind == "integer"}

#: the free range of a length and of a count (docs/problem-file.md, "Fixed or free")
LENGTH_RANGE_KEYS = ("lower", "upper", "initial")
COUNT_RANGE_KEYS = ("lower", "upper", "choices")


#: the keys of a problem file that say how it is solved, not what is solved
METHOD_KEYS = ("solver", "pareto")


@dataclass(frozen=True)
class Options:
    """How a problem is solved, kept apart from what is solved: the solve's settings (the
    file's ``solver:``) and the Pareto sweep's (its ``pareto:``; None: the sweep's defaults).
    :func:`read_options` reads them from a mapping by the loader's rules, a problem's own are
    :attr:`Problem.method`, and ``solve(problem, options=...)`` / ``pareto(...)`` take them."""

    solver: SolverSettings = SolverSettings()
    pareto: Any = None


def read_options(data: Any, where: str = "options", base: Options | None = None) -> Options:
    """Options given as a mapping ``{"solver": {...}, "pareto": {...}}``, each key read by the
    loader's rules (a bad one raises :class:`ProblemError` naming it). The solver keys given
    replace those of ``base`` (a problem's own), the rest kept; a ``pareto`` mapping is a
    whole section (its keys not given at their defaults)."""
    base = base or Options()
    r = Reader(where)
    top = r.mapping(data, "")
    r.known_keys(top, "", set(METHOD_KEYS))
    solver = _read_solver(r, top.get("solver", {}), base.solver)
    pareto = base.pareto
    if "pareto" in top:
        pareto = _pareto_parser()(top["pareto"], r.sub("pareto"))
    return Options(solver=solver, pareto=pareto)


def _pareto_parser():
    module, func = SECTION_PARSERS["pareto"].split(":")
    return getattr(import_module(module), func)


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
    #: ``regulation.eccentricity: {lower, upper}``: δ, the ripple cap and the transmission
    #: angle held over the whole interval (its ends are also the listed ``eccentricities``)
    eccentricity_range: tuple[float, float] | None = None
    solver: SolverSettings = SolverSettings()
    sections: Mapping[str, Any] = field(default_factory=dict)
    source: str = "<dict>"

    @property
    def model(self):
        return get_mechanism(self.mechanism)

    @property
    def quantity_bounds(self) -> tuple:
        """The bounds held as bounds on a quantity
        (:class:`optdesign.quantities.criteria.QuantityConstraint`): every side of
        ``constraints.bounds`` but those the envelope's own criteria hold (the ratio's and
        the transmission angle's floors, and the ripple's cap where the objective brings it)."""
        return generic(self.constraints.bounds, self._held_apart())

    def with_quantity_bounds(self, specs) -> "Problem":
        """The same problem with ``specs`` as its bounds on quantities (the sides the
        envelope's criteria hold kept as they are)."""
        bounds = with_generic(self.constraints.bounds, specs, self._held_apart())
        return replace(self, constraints=replace(self.constraints, bounds=bounds))

    def with_limit(self, name: str, side: str, value: float | None) -> "Problem":
        """The same problem with one side of the bound on quantity ``name`` at ``value``
        (None drops it): :meth:`Constraints.with_limit`."""
        return replace(self, constraints=self.constraints.with_limit(name, side, value))

    def _held_apart(self) -> frozenset:
        return held_apart("max_ripple" in objectives()[self.objective.minimize].requires)

    @property
    def count_variable(self) -> Variable:
        return self.design[self.model.count_variable]

    def counts(self) -> list[int]:
        return self.count_variable.admissible()

    def counts_text(self) -> str:
        """The admissible counts as a message names them: ``6``, or ``2–12``."""
        admitted = self.counts()
        return f"{admitted[0]}–{admitted[-1]}" if len(admitted) > 1 else str(admitted[0])

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

    # --------------------------------------------------------------- validated variants
    @property
    def method(self) -> Options:
        """How this problem's file says to solve it (its ``solver:`` and ``pareto:``)."""
        return Options(solver=self.solver, pareto=self.sections.get("pareto"))

    def with_options(self, options) -> "Problem":
        """The same problem to be solved another way: ``options`` an :class:`Options`, or a
        mapping ``{"solver": {...}, "pareto": {...}}`` read by :func:`read_options` over
        this problem's own; checked as a file is (a Pareto section's counts admissible)."""
        if isinstance(options, Mapping):
            options = read_options(options, f"{self.source}: options", base=self.method)
        if not isinstance(options, Options):
            raise TypeError(f"options are an Options or a mapping of solver: and pareto: "
                            f"(got {type(options).__name__})")
        if not isinstance(options.solver, SolverSettings):
            raise TypeError(f"Options.solver is a SolverSettings (got "
                            f"{type(options.solver).__name__})")
        section = type(_pareto_parser()({}, Reader(self.source).sub("pareto")))
        if options.pareto is not None and not isinstance(options.pareto, section):
            raise TypeError(f"Options.pareto is a {section.__name__} or None (got "
                            f"{type(options.pareto).__name__})")
        sections = {k: v for k, v in self.sections.items() if k != "pareto"}
        if options.pareto is not None:
            sections["pareto"] = options.pareto
        return _checked_variant(Reader(self.source),
                                replace(self, solver=options.solver, sections=sections))

    def with_design(self, **changes) -> "Problem":
        """The problem with design keys given anew, each read by the loader's rules (a
        number fixes a length, ``{lower, upper[, initial]}`` frees it; the count an integer,
        ``{lower, upper}`` or ``{choices: [...]}``), then checked as a file is. Raises
        :class:`ProblemError` naming the key."""
        r = Reader(self.source)
        raw = {k: raw_variable(v) for k, v in self.design.items()} | changes
        problem = replace(self, design=_read_design(r, {"design": raw}, self.model))
        return _checked_variant(r, problem)

    def with_bounds(self, **bounds) -> "Problem":
        """The problem with lengths freed between new bounds, ``l3=(30, 90)``; the initial
        value kept where it lies inside them."""
        changes = {}
        for name, pair in bounds.items():
            if not isinstance(pair, (tuple, list)) or len(pair) != 2:
                raise ProblemError(f"{self.source}: design.{name}: bounds are a pair "
                                   f"(lower, upper) (got {shown(pair)})")
            entry = {"lower": pair[0], "upper": pair[1]}
            old = self.design.get(name)
            start = old.start() if isinstance(old, Variable) else None
            if isinstance(start, float) and all(isinstance(b, (int, float)) and
                                                not isinstance(b, bool) for b in pair) \
                    and pair[0] <= start <= pair[1]:
                entry["initial"] = start
            changes[name] = entry
        return self.with_design(**changes)

    def with_eccentricities(self, eccentricity) -> "Problem":
        """The problem held at other eccentricities: a list of fractions in (0, 1], or an
        interval ``{"lower": ..., "upper": ...}`` (``regulation.eccentricity``'s rules)."""
        r = Reader(self.source)
        ecc, interval = _read_regulation(r, {"eccentricity": eccentricity})
        problem = replace(self, eccentricities=ecc, eccentricity_range=interval)
        if self.objective.robust == "worst_case":
            _check_robust(r, self.objective, interval, self.sections)
        return _checked_variant(r, problem)

    def checked_values(self, values: Mapping) -> dict[str, float]:
        """``values`` (design keys to numbers: a :class:`SolveResult`'s ``.design``) checked
        by the loader's rules: known keys, lengths positive finite numbers, the count a whole
        number the problem admits (as ``--design`` checks it). Raises :class:`ProblemError`
        naming the key."""
        r = Reader(self.source)
        if not isinstance(values, Mapping):
            raise ProblemError(f"{self.source}: a design is a mapping of design keys to "
                               f"values (got {type(values).__name__})")
        r.known_keys(values, "design", {v.name for v in self.model.variables})
        out = {}
        for spec in self.model.variables:
            if spec.name not in values:
                continue
            key = f"design.{spec.name}"
            out[spec.name] = float(r.integer(values[spec.name], key, int(spec.minimum),
                                             MAX_COUNT)) if spec.integer else \
                r.number(values[spec.name], key, positive=True)
        count = self.model.count_variable
        if count in out and int(out[count]) not in self.counts():
            raise ProblemError(f"{self.source}: design.{count} must be a count the problem "
                               f"admits ({self.counts_text()}; got {int(out[count])})")
        return out


    def require_section(self, key: str):
        """The parsed ``key:`` section, or a ProblemError naming the file when it is missing."""
        if key not in self.sections:
            raise ProblemError(f"{self.source}: {key} is required by this command "
                               f"(add a {key}: section)")
        return self.sections[key]


# --------------------------------------------------------------------------- loading
def load_problem(path: str | Path) -> Problem:
    """Read and validate a YAML problem file, within the limits of
    :mod:`optdesign.problem.yaml_text` (size, nesting, aliases, duplicate keys)."""
    path = Path(path)
    where = _printable(path.name) or str(path)
    data = parse(read_text(path), where)
    if data is None:
        raise ProblemError(f"{where}: the file is empty")
    return problem_from_dict(data, where=where, default_name=name_from_stem(path.stem))


def _printable(text: str) -> str:
    """``text`` with every character that would break a one-line message replaced by '?'."""
    return "".join(c if c.isprintable() else "?" for c in text)


def name_from_stem(stem: str) -> str:
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
    mechanism_name = r.choice(top["mechanism"], "mechanism", known())
    mech = get_mechanism(mechanism_name)
    if "input_speed" not in top:
        raise r.error("input_speed", "is required (crank speed ω1, rad/s)")
    input_speed = r.number(top["input_speed"], "input_speed", positive=True)
    stroke = r.choice(top.get("stroke", "forward"), "stroke", mech.strokes)

    design = _read_design(r, top, mech)
    options = _read_options(r, top.get("options", {}), mech)
    ecc, ecc_range = _read_regulation(r, top.get("regulation", {}))
    constraints, angle = _read_constraints(r, top.get("constraints", {}), mech, ecc)
    objective, older = _read_objective(r, top.get("objective", {}))
    constraints = _older_keys(r, constraints,
                              older | {"min_transmission_angle_deg": angle})
    _check_required(r, objective, constraints)
    _check_least_count(r, objective, design, mech)
    solver = _read_solver(r, top.get("solver", {}))
    sections = {}
    for key, target in SECTION_PARSERS.items():
        if key in top:
            module, func = target.split(":")
            sections[key] = getattr(import_module(module), func)(top[key], r.sub(key))
    if objective.robust == "worst_case":
        _check_robust(r, objective, ecc_range, sections)
    for key in constraints.extra:
        owner = EXTRA_CONSTRAINT_SECTIONS.get(key)
        if owner is not None and owner not in sections:
            raise r.error(f"constraints.{key}", f"needs a {owner}: section")
    problem = Problem(name=name, mechanism=mechanism_name, input_speed=input_speed,
                      stroke=stroke, design=design, options=options, constraints=constraints,
                      objective=objective, eccentricities=ecc, eccentricity_range=ecc_range,
                      solver=solver,
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
    warn_implausible(problem)
    return problem


def raw_variable(v: Variable):
    """A design key as a problem file writes it."""
    if v.value is not None:
        return v.value
    if v.choices is not None:
        return {"choices": list(v.choices)}
    out = {"lower": v.lower, "upper": v.upper}
    if v.initial is not None:
        out["initial"] = v.initial
    return out


def _checked_variant(r, problem: Problem) -> Problem:
    """A variant made in code checked as a loaded file is: sections, the regulated scale and
    the mechanism's own check of the start design."""
    for section in problem.sections.values():
        if hasattr(section, "check_problem"):
            section.check_problem(problem)
    _check_regulated_scale(r, problem)
    try:
        problem.model.check_values(problem.start_values(), problem.counts()[0])
    except ProblemError as exc:
        raise ProblemError(f"{problem.source}: {exc}") from None
    return problem


def _check_robust(r, objective: Objective, ecc_range, sections) -> None:
    """``objective.robust: worst_case`` needs the box (a tolerances: section), the least-ripple
    objective and listed eccentricities (a regulation interval's slots are not combined with
    the scenarios)."""
    if "tolerances" not in sections:
        raise r.error("objective.robust", "worst_case needs a tolerances: section (the box "
                                          "of parts)")
    if objective.minimize != "ripple":
        raise r.error("objective.robust", f"worst_case needs minimize: ripple (got "
                                          f"{objective.minimize})")
    if ecc_range is not None:
        raise r.error("objective.robust", "worst_case needs listed eccentricities, not an "
                                          "interval")


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
    (results/NAME/, made safe by optdesign.outputs.checks)."""
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
    if isinstance(value, list):
        raise r.error(key, f"must be a number or a range {{lower, upper, initial}} (got a list "
                           f"{shown(value)}); {_range_hint(spec.name, value)}")
    if not isinstance(value, Mapping):
        return Variable(spec.name, value=r.number(value, key, positive=True))
    entry = r.mapping(value, key)
    r.known_keys(entry, key, set(LENGTH_RANGE_KEYS))
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
    if isinstance(value, list):
        raise r.error(key, f"must be an integer, a range {{lower, upper}} or {{choices: [...]}} "
                           f"(got a list {shown(value)}); to try each of them write "
                           f"{spec.name}: {{choices: {_flow(value)}}}")
    if not isinstance(value, Mapping):
        return Variable(spec.name, value=float(r.integer(value, key, low, MAX_COUNT)))
    entry = r.mapping(value, key)
    r.known_keys(entry, key, set(COUNT_RANGE_KEYS))
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


def _range_hint(name: str, items: list) -> str:
    """How to write the free range a list of numbers was probably meant to be."""
    numbers = [v for v in items if isinstance(v, (int, float)) and not isinstance(v, bool)
               and math.isfinite(v)]
    if len(numbers) == len(items) and len(numbers) in (2, 3):
        lower, upper = min(numbers[:2]), max(numbers[:2])
        initial = f", initial: {_flow(numbers[2])}" if len(numbers) == 3 else ""
        return (f"to free it write {name}: {{lower: {_flow(lower)}, upper: {_flow(upper)}"
                f"{initial}}}")
    return f"to free it write {name}: {{lower: L, upper: U}}"


def _flow(value) -> str:
    """``value`` as short YAML flow text, for a message's suggestion."""
    if isinstance(value, list):
        return "[" + ", ".join(_flow(v) for v in value[:8]) + (", ..." if len(value) > 8 else "") \
            + "]"
    if isinstance(value, float) and value.is_integer() and abs(value) < 1e15:
        return str(int(value))
    return shown(value, 20)


def _read_options(r, raw, mech) -> dict[str, str]:
    raw = r.mapping(raw, "options")
    specs = {o.name: o for o in mech.options}
    r.known_keys(raw, "options", set(specs))
    options = mech.default_options()
    for k, v in raw.items():
        options[k] = r.choice(v, f"options.{k}", specs[k].choices)
    return options


def _read_constraints(r, raw, mech, eccentricities) -> Constraints:
    raw = r.mapping(raw, "constraints")
    quantities = set(known_quantities())
    r.known_keys(raw, "constraints", GENERAL_CONSTRAINT_KEYS | mech.constraint_keys |
                 EXTRA_CONSTRAINT_KEYS | quantities)
    kw = {k.name: k.read(r, raw[k.name], f"constraints.{k.name}") for k in CONSTRAINT_KEYS
          if k.name in GENERAL_CONSTRAINT_KEYS and k.name in raw}
    kw["own"] = {k.name: k.read(r, raw[k.name], f"constraints.{k.name}") if k.name in raw
                 else k.default for k in mech.constraint_declarations}
    kw["bounds"] = tuple(read_bound(r, k, raw[k], eccentricities)
                         for k in sorted(quantities) if k in raw)
    kw["extra"] = {k: v for k, v in raw.items() if k in EXTRA_CONSTRAINT_KEYS}
    angle = kw.pop("min_transmission_angle_deg", None)
    return Constraints(**kw), angle


#: the value of an older key that holds nothing (no floor)
_NO_BOUND = {"min_ratio": 0.0, "min_transmission_angle_deg": 0.0}


def _older_keys(r, constraints: Constraints, older: dict) -> Constraints:
    """The older keys (``objective.min_ratio``, ``objective.max_ripple``,
    ``constraints.min_transmission_angle_deg``: ``older``, by key, None where the file does
    not give it) read into the bounds on their quantities (optdesign.quantities.bounds); the
    transmission angle at its default where neither name gives it. Giving both names of one
    bound is an error; ``spelled`` records the name the file used."""
    bounds, spelled = constraints.bounds, {}
    for (name, side), (section, key) in ALIASES.items():
        given = math.isfinite(side_of(bounds, name, side))
        value = older.get(key)
        if given and value is not None:
            raise r.error(f"constraints.{name}.{side}",
                          f"and {section}.{key} name the same bound: give one")
        if given:
            spelled[f"{name}.{side}"] = f"constraints.{name}.{side}"
            continue
        if value is not None:
            spelled[f"{name}.{side}"] = f"{section}.{key}"
        if value is None and key == "min_transmission_angle_deg":
            value = DEFAULT_MIN_TRANSMISSION_ANGLE_DEG
        if value is not None and value != _NO_BOUND.get(key):
            bounds = with_side(bounds, name, side, value)
    return replace(constraints, bounds=tuple(sorted(bounds, key=lambda b: b.name)),
                   spelled=spelled)


def _read_objective(r, raw) -> tuple[Objective, dict]:
    """The objective, and the older keys of bounds it gives (``min_ratio``,
    ``max_ripple``), by key."""
    raw = r.mapping(raw, "objective")
    r.known_keys(raw, "objective", names(OBJECTIVE_KEYS))
    kw = {k.name: k.read(r, raw[k.name], f"objective.{k.name}") for k in OBJECTIVE_KEYS
          if k.name in raw}
    older = {k: kw.pop(k) for k in ("min_ratio", "max_ripple") if k in kw}
    return Objective(**kw), older


def _check_required(r, objective: Objective, constraints: Constraints) -> None:
    """The bounds the objective needs (``max_ripple`` with ``-ratio``), given by their older
    name or by their own (``constraints.ripple.upper``)."""
    for key in objectives()[objective.minimize].requires:
        if getattr(constraints, key) is None:
            also = " (or constraints.ripple.upper)" if key == "max_ripple" else ""
            raise r.error(f"objective.{key}", f"is required when minimize is "
                                              f"{objective.minimize}{also}")


def _check_least_count(r, objective: Objective, design, mech) -> None:
    """``minimize: phases`` asks for the least of several admissible counts: a count fixed
    (one number, or one choice) leaves nothing to choose."""
    if objective.minimize != "phases":
        return
    count = design[mech.count_variable]
    admissible = count.admissible()
    if len(admissible) < 2:
        raise r.error(f"design.{mech.count_variable}",
                      f"is fixed at {admissible[0]}: minimize: phases picks the least of "
                      f"several counts; give {mech.count_variable}: {{lower, upper}} or "
                      f"{{choices: [...]}}")


def _read_regulation(r, raw) -> tuple[tuple[float, ...], tuple[float, float] | None]:
    """(the listed eccentricities, the interval or None). An interval's ends are its listed
    eccentricities."""
    raw = r.mapping(raw, "regulation")
    r.known_keys(raw, "regulation", names(REGULATION_KEYS))
    declared, interval = REGULATION_KEYS[0].alternatives
    values = raw.get("eccentricity", REGULATION_KEYS[0].default)
    if isinstance(values, dict):
        r.known_keys(values, "regulation.eccentricity", names(interval.keys))
        ends = []
        for key in interval.keys:
            path = f"regulation.eccentricity.{key.name}"
            if key.name not in values:
                raise r.error(path, "is required (an interval {lower, upper} of fractions "
                                    "in (0, 1])")
            ends.append(key.read(r, values[key.name], path))
        lower, upper = ends
        if not upper > lower:
            raise r.error("regulation.eccentricity.upper",
                          f"must exceed lower (got {upper:g} <= {lower:g}); one fraction is "
                          f"a list, eccentricity: [{upper:g}]")
        return (lower, upper), (lower, upper)
    if not isinstance(values, list) or not values:
        raise r.error("regulation.eccentricity", "must be a non-empty list of fractions in "
                                                 "(0, 1] or an interval {lower, upper}")
    if len(values) > declared.max_items:
        raise r.error("regulation.eccentricity", f"must list at most {declared.max_items} "
                                                 f"fractions (got {len(values)})")
    out = []
    for v in values:
        e = r.number(v, "regulation.eccentricity", positive=True)
        if e > declared.item.upper:
            raise r.error("regulation.eccentricity", f"fractions must lie in (0, 1] (got {e:g})")
        if e < declared.item.lower:
            raise r.error("regulation.eccentricity", f"fractions must be at least "
                                                     f"{declared.item.lower:g} (got {e:g})")
        out.append(e)
    return tuple(out), None


def _read_solver(r, raw, base: SolverSettings = SolverSettings()) -> SolverSettings:
    """``solver:``: the keys given replace those of ``base``."""
    raw = r.mapping(raw, "solver")
    r.known_keys(raw, "solver", names(SOLVER_KEYS))
    return replace(base, **{k.name: k.read(r, raw[k.name], f"solver.{k.name}")
                            for k in SOLVER_KEYS if k.name in raw})


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

    def choice(self, value, key: str, choices) -> str:
        """Text that is one of ``choices``; else the error lists them and suggests the one
        most likely meant (a misspelling, another case)."""
        text = self.text(value, key)
        if text not in choices:
            hint = suggestion(text, {str(c) for c in choices})
            hint = f"; did you mean {hint}?" if hint else ""
            raise self.error(key, f"must be one of {', '.join(map(str, choices))} "
                                  f"(got {text!r}{hint})")
        return text

    def known_keys(self, value: Mapping, key: str, allowed: set[str]) -> None:
        """Every key of ``value`` in ``allowed``; else the error names the key, suggests the
        nearest known one (a misspelling, another case, ``min`` for ``lower``) and lists
        them all."""
        for k in value:
            if k not in allowed:
                hint = suggestion(k, allowed)
                hint = f"did you mean {hint}? " if hint else ""
                k = k if k.isprintable() and len(k) <= 40 else shown(k, 40)
                path = f"{key}.{k}" if key else k
                raise self.error(path, f"is not a known key; {hint}known: "
                                       f"{', '.join(sorted(allowed))}")

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


#: words meant for a known key that no spelling distance finds
SYNONYMS = {"min": "lower", "max": "upper", "minimum": "lower", "maximum": "upper",
            "low": "lower", "high": "upper", "lb": "lower", "ub": "upper", "from": "lower",
            "to": "upper", "start": "initial", "init": "initial", "guess": "initial",
            "x0": "initial", "values": "choices", "options": "choices"}


def suggestion(key: str, allowed: set[str]) -> str | None:
    """The known key ``key`` was most likely meant to be, or None: a synonym, the same key in
    another case, or the closest spelling (:func:`difflib.get_close_matches`)."""
    if len(key) > 100:
        return None
    folded = {a.lower(): a for a in allowed}
    low = key.lower()
    if SYNONYMS.get(low) in allowed:
        return SYNONYMS[low]
    if low in folded:
        return folded[low]
    close = difflib.get_close_matches(low, list(folded), n=1, cutoff=0.6)
    return folded[close[0]] if close else None

"""``optdesign analyze``: evaluate a design exactly, every stroke and every listed eccentricity."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from optdesign.envelope.sampled import StrokeFigures
from optdesign.errors import ProblemError
from optdesign.evaluation.design import Design
from optdesign.evaluation.figures import evaluate
from optdesign.evaluation.regulation import curve_over_range, worst_over_range
from optdesign.evaluation.ripples import ripple_label, ripples_of_quantities
from optdesign.outputs.tabular import Tabular
from optdesign.outputs.units import design_units, gear_ratio_text, input_speed_text, stamped
from optdesign.quantities import design_quantities, unit_text
from optdesign.quantities.criteria import Measured, searched_quantities
from optdesign.solver.verify import checks


@dataclass
class AnalysisResult(Tabular):
    """What ``analyze`` prints: the contract's keys first (docs/contract.md)."""

    assembles: bool
    min_transmission_angle_deg: float | None
    strokes: dict[str, StrokeFigures]
    design: dict[str, float]
    mechanism: str
    input_speed: float
    chains_min_transmission_angle_deg: list[float] = field(default_factory=list)
    regulation: list[dict] = field(default_factory=list)
    failure: dict | None = None
    sections: dict[str, dict] = field(default_factory=dict)
    #: the problem file's constraints checked on this design by the exact evaluator: name,
    #: satisfied, margin (>= 0 when satisfied; negative: by how much it is violated), unit
    constraints: list[dict] = field(default_factory=list)
    #: with a regulation interval: its ends, and the worst δ and least transmission angle over
    #: it with their eccentricities (``eccentricity_range, worst_eccentricity, delta,
    #: angle_eccentricity, min_transmission_angle_deg``)
    regulation_range: dict | None = None
    #: every quantity's exact value (:func:`optdesign.quantities.quantities_of`: ``values``
    #: and ``per_eccentricity``); empty when the design does not assemble
    quantities: dict = field(default_factory=dict)
    #: which δ the problem names (its ``objective.ripple``) and its regulation interval
    ripple_definition: str = "midrange"
    eccentricity_range: tuple | None = None
    count_variable: str = "phases"
    #: with several admissible counts: the analysis of each, in order (``analyze_counts``);
    #: this result's own keys are the first count's
    per_count: list = field(default_factory=list)

    def summary(self) -> str:
        lengths = ", ".join(f"{k} = {v:g}" for k, v in self.design.items())
        if not self.assembles:
            return f"{self.mechanism} ({lengths}): does not assemble: {self.failure['message']}"
        named = self.ripples()
        delta = f"{named.worst.text(6)}, " if named is not None else ""
        ratio = self.quantities.get("values", {}).get("ratio")
        ratio = f"ratio = {ratio:.6f}, " if ratio is not None else ""
        return (f"{self.mechanism} ({lengths}): {delta}{ratio}least transmission angle "
                f"{self.min_transmission_angle_deg:.2f}°")

    def ripples(self):
        """The design's δ named (:class:`optdesign.evaluation.ripples.Ripples`); None when it
        does not assemble or holds no ripple."""
        if not self.assembles:
            return None
        return ripples_of_quantities(self.ripple_definition, self.quantities,
                                     self.eccentricity_range)

    def to_frame(self):
        """One row per listed eccentricity and stroke: the exact ω_max, ω_min, midrange and
        time mean (rad/s), δ (midrange and mean) and the ratio."""
        import pandas as pd

        rows = [{"eccentricity": r["eccentricity"], "stroke": stroke,
                 "min_transmission_angle_deg": r["min_transmission_angle_deg"], **figures}
                for r in self.regulation for stroke, figures in r["strokes"].items()]
        return pd.DataFrame(rows)

    def to_dict(self, each: bool = True) -> dict:
        """The contract's keys (the first count's, with several), and with ``each`` and
        several counts ``per_count``: each count's keys, with its ``count``."""
        out = {
            "assembles": self.assembles,
            "min_transmission_angle_deg": self.min_transmission_angle_deg,
            "strokes": {k: v.to_dict() for k, v in self.strokes.items()},
            "mechanism": self.mechanism,
            "input_speed": self.input_speed,
            "design": self.design,
            "chains_min_transmission_angle_deg": self.chains_min_transmission_angle_deg,
            "regulation": self.regulation,
        }
        if self.regulation_range is not None:
            out["regulation_range"] = self.regulation_range
        if self.failure:
            out["failure"] = self.failure
        out["constraints"] = self.constraints
        out["quantities"] = self.quantities
        named = self.ripples()
        if named is not None:
            out["delta_named"] = named.to_dict()
        out.update(self.sections)
        if self.per_count and each:
            out["per_count"] = [{"count": r.design[self.count_variable]} |
                                {k: v for k, v in r.to_dict(each=False).items()
                                 if k not in ("schema_version", "units")}
                                for r in self.per_count]
        return stamped(out, design_units(self.mechanism))


def ripples_of_analysis(problem, result: AnalysisResult):
    """The design's δ named (:class:`optdesign.evaluation.ripples.Ripples`): the worst over
    the listed eccentricities (or the interval) and where it falls, and δ at each; None when
    it does not assemble."""
    return result.ripples()


def analyze_counts(problem) -> AnalysisResult:
    """:func:`analyze` of the problem's design at each admissible count (a file with
    ``phases: {choices: [...]}`` or ``{lower, upper}``): the first count's result, holding
    every count's in ``per_count`` (one count: its result alone)."""
    counts = problem.counts()
    if len(counts) == 1:
        return analyze(problem)
    key = problem.model.count_variable
    each = [analyze(problem.with_design(**{key: n})) for n in counts]
    first = each[0]
    first.per_count = each
    return first


def transmission_angles(design: Design, eccentricity: float = 1.0,
                        n_grid: int = 720) -> np.ndarray:
    """Least transmission angle of every chain, degrees (:meth:`Design.transmission_angles`)."""
    return design.transmission_angles(eccentricity, n_grid)


def analyze(problem, values: dict | None = None, every_stroke: bool = True) -> AnalysisResult:
    """Exact figures of the problem's design (fixed and initial values) or of ``values``.

    A design that does not assemble at some eccentricity comes back with ``assembles`` false
    and a ``failure`` naming the chain and the crank angle; nothing is computed past it.
    ``every_stroke`` False evaluates the speed figures (``strokes``, ``regulation``) of the
    problem's stroke alone, as the explorer shows them; δ, the quantities and the
    constraints are the problem's stroke's either way, the same figures.
    """
    design = Design.from_problem(problem, values)
    mech = design.model
    result = AnalysisResult(assembles=True, min_transmission_angle_deg=None, strokes={},
                            design={k: float(v) for k, v in design.values.items()},
                            mechanism=problem.mechanism, input_speed=problem.input_speed)
    result.design[mech.count_variable] = design.count
    result.ripple_definition = problem.objective.ripple
    result.count_variable = mech.count_variable
    result.eccentricity_range = problem.eccentricity_range
    eccentricities = sorted(set(problem.eccentricities) | {1.0}, reverse=True)
    ev = evaluate(design, problem.stroke, problem.input_speed, eccentricities,
                  mech.strokes if every_stroke else (problem.stroke,))
    if isinstance(ev.failure, ProblemError):
        raise ev.failure
    if ev.failure is None and problem.eccentricity_range is not None:
        # the whole interval, as the solve's verification sees it
        worst = worst_over_range(design, problem.stroke, problem.input_speed,
                                 problem.objective.ripple, *problem.eccentricity_range,
                                 quantities=searched_quantities(design))
        if worst.failure is not None:
            ev.failure, ev.failed_eccentricity = worst.failure, worst.failed_eccentricity
        else:
            ev.worst, ev.worst_definition = worst, problem.objective.ripple
            result.regulation_range = {
                "eccentricity_range": [worst.lower, worst.upper],
                "worst_eccentricity": worst.eccentricity, "delta": worst.delta,
                "angle_eccentricity": worst.angle_eccentricity,
                "min_transmission_angle_deg": worst.min_angle_deg}
    if ev.failure is not None:
        exc = ev.failure
        result.assembles = False
        result.failure = {"chain": exc.chain, "phi_deg": exc.phi_deg,
                          "eccentricity": ev.failed_eccentricity, "message": str(exc)}
        return result
    for x in ev.per_e:
        angles = x.chain_angles_deg
        if x.eccentricity == 1.0:
            result.strokes = x.figures
            result.chains_min_transmission_angle_deg = [float(a) for a in angles]
            result.min_transmission_angle_deg = float(angles.min())
        if x.eccentricity in problem.eccentricities:
            result.regulation.append({"eccentricity": x.eccentricity,
                                      "min_transmission_angle_deg": float(angles.min()),
                                      "strokes": {k: v.to_dict() for k, v in x.figures.items()}})
    for key, section in problem.sections.items():
        if hasattr(section, "analyze"):
            result.sections[key] = section.analyze(problem, result)
    result.constraints = check_constraints(problem, ev)
    result.quantities = design_quantities(problem, ev)
    return result


def check_constraints(problem, ev) -> list[dict]:
    """Every constraint of the problem checked on the evaluation ``ev`` (listed
    eccentricities and e = 1) exactly as the solver's verification checks an optimum
    (:func:`optdesign.solver.verify.checks`), without evaluating the design again."""

    return [{"name": criterion.name, "satisfied": holds,
             "margin": 0.0 - amount if np.isfinite(amount) else None,
             "unit": criterion.unit or "-"}
            for criterion, amount, holds in checks(problem, Measured.of(problem, ev))]


def format_counts(result: AnalysisResult) -> str:
    """The table of :func:`analyze_counts`: one row per admissible count (δ named as the
    problem names it, the ratio, the least transmission angle, the constraints)."""
    key = result.count_variable
    rows = []
    for r in result.per_count:
        named = r.ripples()
        if named is None:
            rows.append(f"  {r.design[key]:>5}  does not assemble: {r.failure['message']}")
            continue
        violated = [c["name"] for c in r.constraints if not c["satisfied"]]
        rows.append(f"  {r.design[key]:>5}  {named.worst.value:9.6f} "
                    f"{_e(named.worst.eccentricity):>6}  "
                    f"{r.quantities['values'].get('ratio', float('nan')):8.4f}  "
                    f"{r.min_transmission_angle_deg:7.2f}  "
                    f"{'violates ' + ', '.join(violated) if violated else 'all satisfied'}")
    first = next((r.ripples() for r in result.per_count if r.ripples() is not None), None)
    label = "δ" if first is None else \
        ripple_label(first.worst.definition, None, first.worst.over, first.worst.interval)
    counts = ", ".join(str(r.design[key]) for r in result.per_count)
    head = [f"every admissible count ({key}: {counts}), the same lengths; δ is {label}:",
            f"  {key:>5}  {'δ':>9} {'at e':>6}  {'ratio':>8}  {'μ_min':>7}  constraints"]
    return "\n".join(head + rows + [f"(the details below are {key} = "
                                      f"{result.design[key]}'s; --{key} N analyses another)"])


def _e(value) -> str:
    return "-" if value is None else f"{value:g}"


def format_analysis(result: AnalysisResult, name: str = "") -> str:
    """A readable table of an analysis, for the terminal."""
    units = design_units(result.mechanism)
    lines = [f"{name or result.mechanism}: {result.mechanism}, "
             f"{input_speed_text(result.input_speed)}"]
    lines.append("design: " + ", ".join(
        f"{k} = {v:g}" + (f" {units[k]}" if units.get(k, "-") != "-" else "")
        for k, v in result.design.items()))
    if not result.assembles:
        lines.append(f"does NOT assemble: {result.failure['message']}")
        return "\n".join(lines)
    lines.append(f"least transmission angle: {result.min_transmission_angle_deg:.2f} deg "
                 f"(per chain: {', '.join(f'{a:.1f}' for a in result.chains_min_transmission_angle_deg)})")
    named = result.ripples()
    if named is not None:
        lines.append(named.worst.text(6))
    for row in result.regulation:
        lines.append("")
        lines.append(f"eccentricity {row['eccentricity']:g}:")
        lines.append(f"  {'stroke':<8} {'ω_max':>8} {'ω_min':>8} {'ω_mid':>8} {'ω_mean':>8} "
                     f"{'δ':>7} {'δ_mean':>7} {'ratio':>7} {'i=1/ratio':>9}")
        for stroke, f in row["strokes"].items():
            lines.append(f"  {stroke:<8} {f['omega_max']:8.3f} {f['omega_min']:8.3f} "
                         f"{f['omega_midrange']:8.3f} {f['omega_mean']:8.3f} {f['delta']:7.4f} "
                         f"{f['delta_mean']:7.4f} {f['ratio']:7.4f} "
                         f"{gear_ratio_text(f['ratio']):>9}")
    if result.regulation:
        lines.append("  speeds in rad/s; ω_mid the midrange (ω_max + ω_min)/2, ω_mean the time "
                     "mean;")
        lines.append("  ratio = output speed / input speed; the gear ratio i = n_in/n_out is "
                     "1/ratio")
    r = result.regulation_range
    if r is not None:
        lines.append("")
        lower, upper = r["eccentricity_range"]
        lines.append(f"over the regulation interval e in [{lower:g}, {upper:g}]: "
                     f"worst δ = {r['delta']:.6f} at e = {r['worst_eccentricity']:.4f}; least "
                     f"transmission angle {r['min_transmission_angle_deg']:.2f} deg at e = "
                     f"{r['angle_eccentricity']:.4f}")
    if result.quantities:
        lines.append("")
        over = "the listed eccentricities" + (
            " and the regulation interval" if "interval" in result.quantities else "")
        lines.append(f"quantities (worst over {over}; the ratio at e = 1):")
        interval = result.quantities.get("interval", {})
        for name, value in result.quantities["values"].items():
            unit = unit_text(name)
            where = f"  (interval's worst at e = {interval[name]['eccentricity']:.4f})" \
                if name in interval else ""
            lines.append(f"  {name:<20} {value:12.6g}{unit}{where}")
    if result.constraints:
        lines.append("")
        lines.append("constraints of the problem file:")
        for c in result.constraints:
            margin = "" if c["margin"] is None else \
                f" (margin {c['margin']:+.4g}{'' if c['unit'] == '-' else ' ' + c['unit']})"
            lines.append(f"  {c['name']:<24} {'satisfied' if c['satisfied'] else 'VIOLATED'}"
                         f"{margin}")
    for key, section in result.sections.items():
        lines.append("")
        lines.append(f"{key}: " + ", ".join(f"{k} = {v:.4g}" if isinstance(v, float) else
                                            f"{k} = {v}" for k, v in section.items()))
    return "\n".join(lines)


#: eccentricities of ``analyze --out``'s figure when the file lists points: (0, 1] from this
#: fraction on (the ratio vanishes at 0), where the design assembles
FIGURE_LEAST_ECCENTRICITY = 0.01
FIGURE_POINTS = 60


def regulation_curve(problem, values: dict | None = None) -> dict:
    """δ, the ratio and the least transmission angle of the problem's design against e: over
    the regulation interval, or over (0, 1] where the design assembles when the file lists
    eccentricities (NaN where it does not); with ``lower``, ``upper`` (the interval or
    None) and ``listed``. What ``analyze --out`` draws into regulation.png."""
    design = Design.from_problem(problem, values)
    span = problem.eccentricity_range
    lower, upper = span if span is not None else (FIGURE_LEAST_ECCENTRICITY, 1.0)
    es = np.linspace(lower, upper, FIGURE_POINTS)
    curve = curve_over_range(design, problem.stroke, problem.input_speed,
                             problem.objective.ripple, es)
    curve.update(interval=span, listed=tuple(problem.eccentricities),
                 ripple=problem.objective.ripple)
    return curve

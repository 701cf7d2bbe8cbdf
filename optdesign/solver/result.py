"""Results of ``optdesign solve``: plain dataclasses with ``to_dict()`` (the contract's keys)."""
from __future__ import annotations

from dataclasses import asdict, dataclass, field

from optdesign.mechanisms import get_mechanism
from optdesign.outputs.tabular import Tabular
from optdesign.outputs.units import design_units, stamped


@dataclass
class StartRecord:
    """One IPOPT run from one start design."""

    start: dict[str, float]
    ipopt_status: str
    iterations: int
    time_s: float
    feasible: bool
    delta: float | None          # exact δ of the returned point (None if it does not assemble)
    note: str = ""
    #: sensitivity of the optimal objective to the ratio bound, d(objective)/d(min_ratio), from
    #: IPOPT's multiplier of that constraint (the Pareto front's local slope dδ/d ratio);
    #: 0 when the bound is slack.
    ratio_multiplier: float | None = None
    #: what binds where IPOPT ended (NLP.active_set): name, kind (bound or constraint), side,
    #: sensitivity d objective / d bound per unit, unit
    active: list[dict] = field(default_factory=list)


@dataclass
class PhaseResult:
    """The optimum of one count (of phases, sections, freewheels), re-verified by the exact
    evaluator."""

    count: int
    status: str                  # optimal | infeasible | failed | outranked (count_order)
    design: dict[str, float] | None = None
    delta: float | None = None                   # exact, worst over the listed eccentricities
    ratio: float | None = None                   # exact, at e = 1
    min_transmission_angle_deg: float | None = None
    surrogate_delta: float | None = None         # what the NLP believed
    surrogate_gap: float | None = None           # surrogate - exact (conservative: >= 0)
    iterations: int = 0
    starts: list[StartRecord] = field(default_factory=list)
    binding: str | None = None                   # the constraint that binds when infeasible
    message: str = ""
    regulation: list[dict] = field(default_factory=list)   # exact figures per eccentricity
    #: the screening before IPOPT: designs screened, passed the filters, basins found,
    #: basins polished, distinct optima among them
    screening: dict = field(default_factory=dict)
    timings: dict = field(default_factory=dict)            # seconds per stage
    #: the active bounds and binding constraints at the optimum, with their sensitivities
    active: list[dict] = field(default_factory=list)
    #: exact dδ/dl, d(ratio)/dl and d(transmission-angle margin)/dl of the optimum for every
    #: length (:meth:`optdesign.evaluation.sensitivity.Sensitivities.to_dict`); empty without an optimum
    sensitivities: dict = field(default_factory=dict)
    #: with a regulation interval: the eccentricity of the largest δ over it (exact)
    worst_eccentricity: float | None = None
    #: a robust solve: the tolerance box's worst δ and least transmission angle of the optimum
    worst_case_delta: float | None = None
    worst_case_min_transmission_angle_deg: float | None = None
    #: no start met the problem: the nearest value of the binding constraint's figure any
    #: design in the bounds reaches (:class:`optdesign.solver.reachable.Reach`), else empty
    reachable: dict = field(default_factory=dict)
    #: ... and the worst of each bound's quantity over the box, by the bound's key
    worst_case_quantities: dict = field(default_factory=dict)
    #: every quantity's exact value of the optimum (:func:`optdesign.quantities.quantities_of`:
    #: ``values`` and ``per_eccentricity``); empty without an optimum
    quantities: dict = field(default_factory=dict)

    @property
    def phases(self) -> int:
        """The count under its old name (deprecated: ``count``)."""
        return self.count

    def to_dict(self) -> dict:
        """Every field; the count as ``count`` and, as before, ``phases``."""
        out = asdict(self)
        return {"phases": out["count"]} | out


@dataclass
class SolveResult(Tabular):
    """What ``optdesign solve`` writes to result.json (docs/contract.md)."""

    name: str
    status: str
    design: dict[str, float] | None
    delta: float | None
    ratio: float | None
    min_transmission_angle_deg: float | None
    solve_time_s: float
    iterations: int
    per_phase: list[PhaseResult]
    objective: dict
    accuracy: dict
    message: str = ""
    stroke: str = "forward"
    mechanism: str = ""
    input_speed: float = 0.0
    sections: dict = field(default_factory=dict)
    #: wall time per stage, seconds: build (the NLPs), screening, ipopt, verification (the
    #: exact checks and the accuracy report); what is left of solve_time_s is bookkeeping
    timings_s: dict = field(default_factory=dict)
    #: the active bounds and binding constraints of the best design (see PhaseResult.active)
    active: list[dict] = field(default_factory=list)
    #: with a regulation interval: the best design's eccentricity of the largest δ over it
    worst_eccentricity: float | None = None
    #: a robust solve: the best design's worst δ over the tolerance box (its objective)
    worst_case_delta: float | None = None
    #: every quantity's exact value of the best design (see PhaseResult.quantities)
    quantities: dict = field(default_factory=dict)
    #: with ``minimize: phases``: the least count meeting the ripple cap and each count's
    #: least δ (:func:`optdesign.solver.least_count.least_count`); empty otherwise
    least_count: dict = field(default_factory=dict)

    def ripples(self):
        """The optimum's δ named (:class:`optdesign.evaluation.ripples.Ripples`): the worst
        over the listed eccentricities (or the interval) and where it falls, and δ at each;
        None without an optimum."""
        from optdesign.evaluation.ripples import ripples_of_quantities

        objective = self.objective or {}
        interval = objective.get("eccentricity_range")
        return ripples_of_quantities(objective.get("ripple", "midrange"), self.quantities,
                                     tuple(interval) if interval else None)

    # ------------------------------------------------- scipy.optimize.OptimizeResult's names
    @property
    def success(self) -> bool:
        """scipy's name: True when a verified optimum was found (``status == "optimal"``)."""
        return self.status == "optimal"

    @property
    def x(self):
        """scipy's name: the best design's lengths as an array, in the mechanism's order
        (None without an optimum); :attr:`design` names them."""
        if self.design is None:
            return None
        import numpy as np

        return np.array([self.design[k] for k in get_mechanism(self.mechanism).lengths])

    @property
    def fun(self) -> float | None:
        """scipy's name: the objective at the optimum (δ, -ratio or the quantity's value, as
        ``objective.minimize`` says; the count with ``minimize: phases``; the robust
        solve's worst δ)."""
        best = self.best_phase()
        if best is None:
            return None
        if self.worst_case_delta is not None:
            return self.worst_case_delta
        minimize = self.objective.get("minimize", "ripple")
        if minimize == "phases":
            return float(best.count)
        value = best.quantities["values"][minimize.lstrip("-")]
        return -value if minimize.startswith("-") else value

    @property
    def nit(self) -> int:
        """scipy's name: IPOPT iterations of the whole solve."""
        return self.iterations

    def best_phase(self) -> PhaseResult | None:
        if self.design is None:
            return None
        return next(p for p in self.per_phase if p.design == self.design)

    @property
    def sensitivities(self) -> dict:
        """The best design's exact derivatives with respect to its lengths (the best phase
        count's :attr:`PhaseResult.sensitivities`; empty without an optimum)."""
        best = self.best_phase()
        return dict(best.sensitivities) if best else {}

    def summary(self) -> str:
        if self.design is None:
            return f"{self.name}: {self.status}" + (f" ({self.message})" if self.message else "")
        least = self.least_count
        count = (f", least count {least['count']} for δ ≤ {least['bound']:g}"
                 if least.get("count") is not None else "")
        return (f"{self.name}: {self.status}{count}, δ = {self.delta:.6g}, ratio = "
                f"{self.ratio:.6g}, least transmission angle "
                f"{self.min_transmission_angle_deg:.2f}° ({self.solve_time_s:.2f} s)")

    def to_frame(self):
        """One row per count (named by its mechanism: phases, sections, freewheels): status,
        exact δ, ratio, least transmission angle, the lengths in mm under their design keys
        (``l0``, … as in every other table; ``frame.attrs["units"]`` gives each column's
        unit), IPOPT iterations, and why a count has no optimum. The lengths' older columns
        ``l0_mm``, … stay one release as deprecated aliases, at the end."""
        import pandas as pd

        model = get_mechanism(self.mechanism)
        lengths = model.lengths
        rows = []
        for p in self.per_phase:
            row = {"count": p.count, model.count_variable: p.count, "status": p.status, "delta": p.delta, "ratio": p.ratio,
                   "min_transmission_angle_deg": p.min_transmission_angle_deg}
            row |= {k: (p.design or {}).get(k) for k in lengths}
            row |= {"iterations": p.iterations, "best": p.design is not None and
                    p.design == self.design, "message": p.message}
            row |= {f"{k}_mm": row[k] for k in lengths}          # deprecated aliases
            rows.append(row)
        frame = pd.DataFrame(rows)
        frame.attrs["units"] = {k: "mm" for k in lengths} | {
            "delta": "-", "ratio": "-", "min_transmission_angle_deg": "deg"}
        frame.attrs["deprecated"] = {f"{k}_mm": k for k in lengths}
        return frame

    def to_dict(self) -> dict:
        """The contract's keys, then ``schema_version`` and ``units``
        (:func:`optdesign.outputs.units.stamped`)."""
        out = asdict(self)
        out["per_phase"] = [p.to_dict() for p in self.per_phase]
        out["sensitivities"] = self.sensitivities
        named = self.ripples()
        if named is not None:
            out["delta_named"] = named.to_dict()
        sections = out.pop("sections")
        out.update(sections)
        return stamped(out, design_units(self.mechanism))

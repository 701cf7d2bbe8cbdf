"""The whole regulation range: a design's worst eccentricity over an interval [lower, upper].

With ``regulation: {eccentricity: {lower, upper}}`` the ripple (and the ripple cap and the
transmission angle) is held at every fraction e of the regulated length in the interval, not at
listed points only. δ(e) is smooth between the eccentricities where the envelope's hand-over
order changes and has kinks there, so the worst e is found on the exact evaluator by a coarse
scan of e and a bounded scalar search (Brent's) on the cells around every local maximum of the
scan (every local minimum, for the transmission angle); the ends are exact points of the scan.
Any other quantity a criterion reads over the interval (a housing radius bound, a least peak
acceleration) is searched the same way on its own exact form
(:meth:`optdesign.quantities.base.Quantity.exact`), towards the side where it grows worse.
docs/formulation.md, "The whole regulation range".
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from optdesign.envelope.exact import exact_figures, search_grid
from optdesign.errors import AssemblyError, ProblemError
from optdesign.quantities import get_quantity

#: eccentricities of the coarse scan over the interval (ends included)
SCAN_POINTS = 17
#: the bounded search stops when e is known to this fraction of the interval
E_TOL_REL = 1e-7
#: a step this share of the interval inside an end tells whether the end is a local maximum
END_STEP_REL = 1e-6


@dataclass
class RangeWorst:
    """The worst of a design over the interval: the largest δ and the least transmission
    angle, each with its eccentricity; ``failure`` when the design does not assemble at some e
    of the interval (``failed_eccentricity``)."""

    lower: float
    upper: float
    eccentricity: float | None = None          # where δ is largest
    delta: float | None = None
    angle_eccentricity: float | None = None    # where the transmission angle is least
    min_angle_deg: float | None = None
    failure: AssemblyError | ProblemError | None = None
    failed_eccentricity: float | None = None
    evaluations: int = 0
    #: every eccentricity evaluated, with its δ and least angle (the scan and the searches)
    points: dict[float, tuple[float, float]] = field(default_factory=dict)
    #: every other quantity searched: its worst over the interval, (eccentricity, value)
    quantities: dict[str, tuple[float, float]] = field(default_factory=dict)

    def interior(self, e: float | None, share: float = 1e-6) -> bool:
        """``e`` lies strictly inside the interval (farther than ``share`` of it from an end)."""
        width = self.upper - self.lower
        return e is not None and self.lower + share * width < e < self.upper - share * width


@dataclass
class _Point:
    """One eccentricity of the search, sampled once: what a quantity's exact form reads
    (``figures`` per stroke, ``sampled`` on the search grid, the least transmission angle)."""

    eccentricity: float
    phi: np.ndarray
    sampled: dict
    figures: dict
    design: object = field(repr=False)

    @property
    def min_angle_deg(self) -> float:
        return float(self.design.transmission_angles(self.eccentricity, phi=self.phi,
                                                     cos_mu=self.sampled["cos_mu"]).min())


class _AtEccentricity:
    """δ, the least transmission angle and any quantity of one design at any e, each e
    sampled and evaluated once. It reads as an evaluation to a quantity's exact form
    (``design``, ``stroke``, ``input_speed``, :meth:`at`)."""

    def __init__(self, design, stroke: str, input_speed: float, definition: str):
        self.design, self.stroke, self.input_speed = design, stroke, input_speed
        self.definition = definition
        self.points: dict[float, tuple[float, float]] = {}
        self.failed: float | None = None
        self.refined: dict[float, bool] = {}
        self._sampled: dict[float, _Point] = {}
        #: quantity name -> {e: exact value}
        self.values: dict[str, dict[float, float]] = {}

    def at(self, e: float) -> _Point:
        """The design sampled and its exact figures at e (AssemblyError where it does not
        assemble)."""
        e = float(e)
        known = self._sampled.get(e)
        if known is None:
            design = self.design
            phi = search_grid(design, e)
            sampled = design.sample(phi, e)
            try:
                design.check_assembly(e, phi=phi, cos_mu=sampled["cos_mu"])
            except AssemblyError:
                self.failed = e
                raise
            figures, _ = exact_figures(design, self.stroke, self.input_speed, e, phi=phi,
                                       sampled=sampled)
            known = _Point(e, phi, sampled, {self.stroke: figures}, design)
            self._sampled[e] = known
        return known

    def __call__(self, e: float, angle: str = "refined") -> tuple[float, float]:
        """(δ, least angle in degrees) at e. ``angle``: ``refined`` (between the samples),
        ``sampled`` (the search grid's least, for the scan) or ``none`` (NaN: the δ
        searches). Raises AssemblyError where the design does not assemble."""
        e = float(e)
        known = self.points.get(e)
        if known is not None and (angle == "none" or self.refined.get(e)
                                  or (angle == "sampled" and np.isfinite(known[1]))):
            return known
        point = self.at(e)
        cos_mu = point.sampled["cos_mu"]
        if angle == "refined":
            mu = point.min_angle_deg
        elif angle == "sampled":
            mu = float(np.degrees(np.arccos(min(np.abs(cos_mu).max(), 1.0))))
        else:
            mu = float("nan")
        self.refined[e] = angle == "refined"
        self.points[e] = (point.figures[self.stroke].ripple(self.definition), mu)
        return self.points[e]

    def quantity(self, name: str, e: float) -> float:
        """The exact value of quantity ``name`` at e."""
        e = float(e)
        values = self.values.setdefault(name, {})
        if e not in values:
            values[e] = float(get_quantity(name).exact(self, e, self.definition))
        return values[e]


def worst_over_range(design, stroke: str, input_speed: float, definition: str,
                     lower: float, upper: float, scan: int = SCAN_POINTS,
                     quantities=()) -> RangeWorst:
    """The largest δ (``definition``: midrange or mean) and the least transmission angle of
    ``design`` over e in [lower, upper]: a scan of ``scan`` eccentricities, then a bounded
    Brent search on the two cells around every local maximum of δ (minimum of the angle) of
    the scan; and the worst of each of ``quantities`` (names) by the same search."""
    at = _AtEccentricity(design, stroke, input_speed, definition)
    out = RangeWorst(lower, upper)
    es = np.linspace(lower, upper, scan) if upper > lower else np.array([lower])
    try:
        values = np.array([at(e, "sampled") for e in es])
        delta, angle = values[:, 0], values[:, 1]
        for j in _local_extremes(delta):
            _refine(lambda e: -at(e, "none")[0], es, j)
        for j in _local_extremes(-angle):
            at(es[j])                                     # the scan's value, refined
            _refine(lambda e: at(e)[1], es, j)
        for name in quantities:
            out.quantities[name] = _worst_quantity(at, name, es)
    except (AssemblyError, ProblemError) as exc:
        out.failure = exc
        out.failed_eccentricity = at.failed
        out.evaluations = len(at.points)
        return out
    out.points = dict(sorted(at.points.items()))
    e_all = np.array(list(out.points))
    d_all = np.array([v[0] for v in out.points.values()])
    # the least angle among the refined ones (a sampled angle is never below the truth)
    a_all = np.array([v[1] if at.refined.get(e) else np.nan for e, v in out.points.items()])
    i = int(np.argmax(d_all))
    out.eccentricity, out.delta = float(e_all[i]), float(d_all[i])
    a_all = np.where(np.isfinite(a_all), a_all, np.inf)
    k = int(np.argmin(a_all))
    out.angle_eccentricity, out.min_angle_deg = float(e_all[k]), float(a_all[k])
    out.evaluations = len(at.points)
    return out


def quantities_over_range(design, stroke: str, input_speed: float, definition: str,
                          lower: float, upper: float, names,
                          scan: int = SCAN_POINTS) -> dict[str, tuple[float, float]]:
    """The worst (e, value) over e in [lower, upper] of each quantity of ``names``, by the
    scan and bounded search of :func:`worst_over_range` (AssemblyError where the design does
    not assemble at an e of the search)."""
    at = _AtEccentricity(design, stroke, input_speed, definition)
    es = np.linspace(lower, upper, scan) if upper > lower else np.array([lower])
    return {name: _worst_quantity(at, name, es) for name in names}


def _worst_quantity(at: _AtEccentricity, name: str, es: np.ndarray) -> tuple[float, float]:
    """(e, value) of the worst of quantity ``name`` over the scan ``es`` and a bounded search
    around every local worst of the scan."""
    sign = 1.0 if get_quantity(name).worst == "max" else -1.0
    values = np.array([at.quantity(name, e) for e in es])
    for j in _local_extremes(sign * values):
        _refine(lambda e: -sign * at.quantity(name, e), es, j)
    found = at.values[name]
    e = max(found, key=lambda x: sign * found[x])
    return float(e), found[e]


def _local_extremes(values: np.ndarray) -> list[int]:
    """Indices of the scan's local maxima (an end counts when it is not below its one
    neighbour; a plateau counts once)."""
    n = values.size
    if n == 1:
        return [0]
    out = []
    for j in range(n):
        left = values[j - 1] if j > 0 else -np.inf
        right = values[j + 1] if j < n - 1 else -np.inf
        if values[j] >= left and values[j] > right or (values[j] > left and values[j] >= right):
            out.append(j)
    return out


def _refine(objective, es: np.ndarray, j: int) -> None:
    """Bounded Brent search for the least ``objective`` on the cells beside scan point j
    (its values are kept by the evaluator's memory)."""
    from scipy.optimize import minimize_scalar

    lo, hi = es[max(j - 1, 0)], es[min(j + 1, es.size - 1)]
    if hi <= lo:
        return
    if j in (0, es.size - 1):       # an end: refine only if the inside rises from it
        step = END_STEP_REL * (es[-1] - es[0]) * (1 if j == 0 else -1)
        if objective(es[j] + step) >= objective(es[j]):
            return
    tol = E_TOL_REL * (es[-1] - es[0])
    minimize_scalar(objective, bounds=(lo, hi), method="bounded",
                    options={"xatol": tol, "maxiter": 100})


def curve_over_range(design, stroke: str, input_speed: float, definition: str,
                     eccentricities) -> dict[str, np.ndarray]:
    """δ, the ratio and the least transmission angle at each of ``eccentricities`` (NaN where
    the design does not assemble): what ``analyze`` plots."""
    out = {k: np.full(len(eccentricities), np.nan) for k in ("delta", "ratio", "angle")}
    for i, e in enumerate(eccentricities):
        e = float(e)
        try:
            phi = search_grid(design, e)
            sampled = design.sample(phi, e)
            design.check_assembly(e, phi=phi, cos_mu=sampled["cos_mu"])
            figures, _ = exact_figures(design, stroke, input_speed, e, phi=phi, sampled=sampled)
            out["delta"][i] = figures.ripple(definition)
            out["ratio"][i] = figures.ratio
            out["angle"][i] = design.transmission_angles(e, phi=phi,
                                                         cos_mu=sampled["cos_mu"]).min()
        except (AssemblyError, ProblemError):
            continue
    out["eccentricity"] = np.asarray(eccentricities, dtype=float)
    return out

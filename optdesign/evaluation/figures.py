"""One exact evaluation of a design: every figure a check, a report or a start guess reads.

Per eccentricity the design is sampled once, on the exact evaluator's search grid; from that one
sampling come the assembly check, the exact output figures of each stroke asked for (crossings
and stationary points by Brent's method, :mod:`optdesign.envelope.exact`), the envelope's hand-over
structure, the angles of the rocker curves' peaks, and the least transmission angle of every
chain. Verification (:mod:`optdesign.solver.verify`), ``analyze`` and the solver's start guess
read it instead of sampling the design again.
"""
from __future__ import annotations

import itertools
import os

from dataclasses import dataclass, field

import numpy as np

from optdesign.envelope.exact import DEFAULT_GRID, Run, exact_figures, search_grid
from optdesign.envelope.sampled import StrokeFigures, driving_speeds
from optdesign.errors import AssemblyError, ProblemError
from optdesign.evaluation.design import Design
from optdesign.evaluation.regulation import RangeWorst, worst_over_range
from optdesign.numerics.kept import keep
from optdesign.quantities.base import forget_maxima
from optdesign.quantities.criteria import interval_quantities


@dataclass
class EccentricityEvaluation:
    """The exact figures of a design at one eccentricity fraction e."""

    eccentricity: float
    figures: dict[str, StrokeFigures]        # per stroke
    runs: list[Run]                          # hand-overs of the evaluated (problem's) stroke
    peak_angles: np.ndarray                  # grid angle of each driving curve's maximum
    chain_angles_deg: np.ndarray             # least transmission angle of every chain
    cos_extreme_angles: np.ndarray           # grid angles of max cos μ, then min cos μ, per chain
    #: the design sampled on the search grid (theta, dtheta, ddtheta, cos_mu): what the turn
    #: quantities read instead of sampling it again
    sampled: dict | None = field(default=None, repr=False, compare=False)
    #: the search grid ``sampled`` and the runs' stationary points were found on
    grid: np.ndarray | None = field(default=None, repr=False, compare=False)

    @property
    def sequence(self) -> tuple[int, ...]:
        """Which curve drives on each run, in crank order (the NLP's hand-over structure)."""
        return tuple(r.curve for r in self.runs)

    @property
    def handovers(self) -> np.ndarray:
        return np.array([r.start for r in self.runs])

    @property
    def min_angle_deg(self) -> float:
        return float(self.chain_angles_deg.min())


@dataclass
class Evaluation:
    """A design evaluated exactly at e = 1 (where the ratio is defined) and the listed e.

    ``failure`` holds the reason when the design does not assemble (or its values make no
    sense to the mechanism); nothing is evaluated past the first eccentricity that fails.
    """

    design: Design
    stroke: str
    input_speed: float
    per_e: list[EccentricityEvaluation] = field(default_factory=list)
    failure: AssemblyError | ProblemError | None = None
    failed_eccentricity: float | None = None
    #: with a regulation interval: the worst δ (of ``worst_definition``) and least
    #: transmission angle over the whole interval (:mod:`optdesign.evaluation.regulation`)
    worst: RangeWorst | None = None
    worst_definition: str = "midrange"
    #: the search grid's size it was evaluated on (:func:`evaluate`'s ``n_grid``)
    n_grid: int = DEFAULT_GRID

    @property
    def assembles(self) -> bool:
        return self.failure is None

    @property
    def eccentricities(self) -> tuple[float, ...]:
        return tuple(x.eccentricity for x in self.per_e)

    def at(self, eccentricity: float) -> EccentricityEvaluation:
        return next(x for x in self.per_e if x.eccentricity == eccentricity)

    @property
    def strokes(self) -> dict[str, StrokeFigures]:
        """Figures of every evaluated stroke at e = 1 (what a section reads of ``analyze``)."""
        return self.at(1.0).figures if self.assembles else {}

    @property
    def figures(self) -> StrokeFigures:
        """Figures of the problem's stroke at e = 1."""
        return self.at(1.0).figures[self.stroke]

    @property
    def ratio(self) -> float:
        return self.figures.ratio

    def ripple(self, definition: str, eccentricities) -> float:
        """Worst δ of the problem's stroke over ``eccentricities`` (and over the regulation
        interval, when it was searched for this definition)."""
        listed = max(self.at(e).figures[self.stroke].ripple(definition) for e in eccentricities)
        if self.worst is not None and self.worst_definition == definition:
            return max(listed, self.worst.delta)
        return listed

    @property
    def min_angle_deg(self) -> float:
        """Least transmission angle over the evaluated eccentricities (and the interval)."""
        least = min(x.min_angle_deg for x in self.per_e)
        return least if self.worst is None else min(least, self.worst.min_angle_deg)


def eccentricities_of(problem) -> tuple[float, ...]:
    """e = 1 first (where the ratio is defined), then the other listed fractions."""
    return (1.0,) + tuple(e for e in problem.eccentricities if e != 1.0)


def evaluate(design: Design, stroke: str, input_speed: float,
             eccentricities=(1.0,), strokes: tuple[str, ...] | None = None,
             n_grid: int = DEFAULT_GRID) -> Evaluation:
    """Evaluate ``design`` once per eccentricity (``eccentricities`` should start with 1).

    ``strokes`` lists the strokes whose figures are wanted (default: ``stroke`` alone); the
    hand-over runs are those of ``stroke``.
    """
    strokes = strokes or (stroke,)
    ev = Evaluation(design, stroke, input_speed, n_grid=n_grid)
    try:
        design.model.check_values(design.values, design.count)
    except ProblemError as exc:
        ev.failure = exc
        return ev
    for e in eccentricities:
        key = _evaluated_key(design, stroke, input_speed, e, strokes, n_grid)
        known = _EVALUATED.get(key)
        if known is None:
            known = _evaluate_at(design, stroke, input_speed, e, strokes, n_grid)
            keep(_EVALUATED, _EVALUATED_SIZE, key, known)
        if isinstance(known, AssemblyError):
            ev.failure, ev.failed_eccentricity = known, e
            return ev
        ev.per_e.append(known)
    return ev


#: the per-eccentricity evaluations of the designs evaluated last, oldest first: a sweep or
#: a solve verifies a design again as the next polish's start (the same figures, exactly)
_EVALUATED: dict = {}
_EVALUATED_SIZE = 64


def _evaluated_key(design: Design, stroke: str, input_speed: float, e: float, strokes,
                   n_grid: int) -> tuple:
    """What an eccentricity's evaluation of ``design`` on a grid of ``n_grid`` is kept under
    (:data:`_EVALUATED`; a refinement's, of its stroke alone, in :data:`_REFINED`)."""
    return (design.mechanism, design.option_key, tuple(sorted(design.values.items())),
            stroke, input_speed, float(e), tuple(strokes), n_grid)


def remember(problem, evaluation: Evaluation) -> None:
    """Keep ``evaluation``, an :func:`evaluate_problem` of ``problem``'s made elsewhere (in a
    process forked from this one: a polish beside the solve), as if it had been made here:
    the next evaluation of that design reads it (the same figures, to the bit)."""
    if not evaluation.assembles:
        return
    design = evaluation.design
    strokes = tuple(evaluation.per_e[0].figures) if evaluation.per_e else ()
    for known in evaluation.per_e:
        key = _evaluated_key(design, evaluation.stroke, evaluation.input_speed,
                             known.eccentricity, strokes, evaluation.n_grid)
        keep(_EVALUATED, _EVALUATED_SIZE, key, known)
    if evaluation.worst is not None and evaluation.worst_definition == problem.objective.ripple:
        keep(_WORST_CACHE, _WORST_CACHE_SIZE,
             _worst_key(problem, design, interval_quantities(problem)), evaluation.worst)


def _evaluate_at(design: Design, stroke: str, input_speed: float, e: float,
                 strokes: tuple[str, ...], n_grid: int):
    """One eccentricity of :func:`evaluate`: its EccentricityEvaluation, or the
    AssemblyError that stops it."""
    phi = search_grid(design, e, n_grid)
    sampled = design.sample(phi, e)
    try:
        design.check_assembly(e, phi=phi, cos_mu=sampled["cos_mu"])
    except AssemblyError as exc:
        return exc
    figures, runs = {}, []
    for s in strokes:
        figures[s], r = exact_figures(design, s, input_speed, e, phi=phi, sampled=sampled)
        if s == stroke:
            runs = r
    speeds = driving_speeds(sampled["dtheta"], stroke)
    angles = design.transmission_angles(e, phi=phi, cos_mu=sampled["cos_mu"])
    cos_mu = sampled["cos_mu"]
    extremes = np.concatenate([phi[np.argmax(cos_mu, axis=1)], phi[np.argmin(cos_mu, axis=1)]])
    return EccentricityEvaluation(e, figures, runs, phi[np.argmax(speeds, axis=1)],
                                  angles, extremes, sampled, phi)


def evaluate_problem(problem, values=None, strokes: tuple[str, ...] | None = None,
                     extra: tuple[float, ...] = (), search: bool = True) -> Evaluation:
    """:func:`evaluate` of the problem's design (or ``values``) at its eccentricities, then at
    ``extra`` ones (the solve's held interior eccentricities, in order); with a regulation
    interval (and ``search``), its worst δ and transmission angle are searched too, and the
    worst of each quantity a criterion reads over the interval (``Evaluation.worst``)."""
    design = Design.from_problem(problem, values)
    ev = evaluate(design, problem.stroke, problem.input_speed,
                  eccentricities_of(problem) + tuple(extra), strokes)
    if problem.eccentricity_range is not None and search and ev.assembles:
        worst = _worst_of(problem, design)
        if worst.failure is not None:
            ev.failure, ev.failed_eccentricity = worst.failure, worst.failed_eccentricity
        else:
            ev.worst, ev.worst_definition = worst, problem.objective.ripple
    return ev


#: the interval searches of the designs evaluated last (a solve verifies one design again
#: whenever its held eccentricities change): key -> RangeWorst
_WORST_CACHE: dict = {}
_WORST_CACHE_SIZE = 32


def refined(design: Design, stroke: str, input_speed: float, e: float,
            factor: int) -> StrokeFigures:
    """The exact figures of ``design``'s ``stroke`` at eccentricity ``e`` on a search grid
    ``factor`` times finer than the evaluator's (:func:`~optdesign.envelope.exact.exact_figures`:
    the solve's accuracy record compares them with the evaluator's), remembered for the
    designs refined last."""
    key = _evaluated_key(design, stroke, input_speed, e, (stroke,), factor * DEFAULT_GRID)
    known = _REFINED.get(key)
    if known is None:
        known, _ = exact_figures(design, stroke, input_speed, e, n_grid=factor * DEFAULT_GRID)
        keep(_REFINED, _REFINED_SIZE, key, known)
    return known


#: :func:`refined`'s figures of the designs refined last (a solve refines its answer, and
#: may refine a count's best optimum ahead, while it waits for a polish beside it)
_REFINED: dict = {}
_REFINED_SIZE = 8


#: the memory's generation (:func:`generation`): this process's pid and a count of forgets
_FORGOTTEN = itertools.count(1)
_GENERATION = [(0, 0)]


def forget(generation: tuple | None = None) -> None:
    """Let go of every evaluation kept (:data:`_EVALUATED`, :data:`_WORST_CACHE`,
    :data:`_REFINED`, and the turn quantities' maxima,
    :func:`optdesign.quantities.base.forget_maxima`): the next evaluation of any design is
    made anew. For a measure of what a new problem costs a warm process: a solve of a problem
    solved before reads its designs' figures from here. The memory's :func:`generation`
    becomes a new one (``generation``: that of the process a kept child computes for, whose
    memory it follows: :func:`optdesign.solver.polishing._polish_of`)."""
    _EVALUATED.clear()
    _WORST_CACHE.clear()
    _REFINED.clear()
    forget_maxima()
    _GENERATION[0] = generation or (os.getpid(), next(_FORGOTTEN))


def generation() -> tuple:
    """Which emptying of the evaluator's memory this process's is since (:func:`forget`):
    a kept child whose memory is of another empties its own too (:func:`follow`)."""
    return _GENERATION[0]


def follow(generation: tuple) -> None:
    """Empty this process's memory of evaluations where it is not of ``generation`` (that
    of the process a kept child computes for, :mod:`optdesign.kept_children`): its memory
    then holds no more than a child forked now would inherit."""
    if generation != _GENERATION[0]:
        forget(generation)


def _worst_of(problem, design: Design) -> RangeWorst:
    """:func:`~optdesign.evaluation.regulation.worst_over_range` of ``design`` over the problem's
    interval, remembered for the last few designs."""
    quantities = interval_quantities(problem)
    key = _worst_key(problem, design, quantities)
    worst = _WORST_CACHE.get(key)
    if worst is None:
        worst = worst_over_range(design, problem.stroke, problem.input_speed,
                                 problem.objective.ripple, *problem.eccentricity_range,
                                 quantities=quantities)
        keep(_WORST_CACHE, _WORST_CACHE_SIZE, key, worst)
    return worst


def _worst_key(problem, design: Design, quantities) -> tuple:
    """What :data:`_WORST_CACHE` keeps ``design``'s search over ``problem``'s interval for
    ``quantities`` (the problem's :func:`interval_quantities`) under."""
    return (problem.mechanism, problem.stroke, problem.input_speed, problem.objective.ripple,
            problem.eccentricity_range, tuple(sorted(problem.options.items())),
            tuple(sorted((k, float(v)) for k, v in design.values.items())), quantities)

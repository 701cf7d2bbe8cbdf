"""A quantity: a named figure of a design over the crank turn, defined once.

Every figure the tool optimises, bounds or reports is a :class:`Quantity`: its name (the key of
the problem file, the JSON documents and the tables), its unit and label, and its exact value
at one eccentricity of an evaluated design. Values at several eccentricities combine into the
*worst* by :attr:`Quantity.worst` (the largest ripple, the least transmission angle).

:class:`TurnQuantity` is the kind a new quantity usually is: the extremes over the turn of a
per-angle expression of the mechanism's CasADi model (joint positions, θ, dθ/dφ, d²θ/dφ²),
reduced to one value. It is written once, as that expression and that reduction, and serves

* the exact evaluation (:meth:`TurnQuantity.exact`): each component's maximum over the turn at
  a stationary point found by Brent's method (:mod:`optdesign.quantities.extremes`);
* the NLP (:meth:`TurnQuantity.function`, :meth:`TurnQuantity.components`): the same
  expression held at exact stationary points, as the peak speed and the transmission angle
  are (:mod:`optdesign.solver.nlp`);
* the screening (:meth:`TurnQuantity.sampled`): the grid's maxima of the same expression.
"""
from __future__ import annotations

import math
from functools import lru_cache
from typing import ClassVar

import casadi as ca
import numpy as np

from optdesign.envelope.exact import search_grid
from optdesign.numerics.kept import keep
from optdesign.quantities.extremes import BREAK_STEP, turn_maxima

#: how a quantity's values combine: into its worst, and across its components
COMBINE = {"max": max, "min": min}


class Quantity:
    """A named figure of a design: ``value = exact(evaluation, e)``.

    ``worst`` is ``"max"`` when a larger value is worse (ripple, housing radius) and
    ``"min"`` when a smaller one is (transmission angle, ratio, swing): the worst over the
    listed eccentricities, and the side a bound naturally takes (an upper bound on a "max"
    quantity, a lower one on a "min" quantity).
    """

    name: ClassVar[str] = ""
    unit: ClassVar[str] = "-"
    label: ClassVar[str] = ""
    meaning: ClassVar[str] = ""
    worst: ClassVar[str] = "max"
    #: the eccentricity a criterion reads it at by default (None: the worst over the listed
    #: ones)
    at: ClassVar[float | None] = None
    #: what it is in a sentence ("the largest ratio any design reaches"); default its name
    words: ClassVar[str] = ""

    def exact(self, evaluation, eccentricity: float, ripple: str = "midrange") -> float:
        """The exact value of the evaluated design at ``eccentricity`` (one it was
        evaluated at)."""
        raise NotImplementedError

    def defined_for(self, design) -> bool:
        """Whether the quantity means something for ``design``'s mechanism (a linkage
        without moving joints has no housing radius)."""
        return True

    def worst_of(self, values) -> float:
        """The worst of several values (e.g. over the listed eccentricities)."""
        return float(COMBINE[self.worst](values))

    def natural_side(self) -> str:
        """``upper`` for a quantity whose larger values are worse, else ``lower``."""
        return "upper" if self.worst == "max" else "lower"

    # ------------------------------------------------------------------ its NLP form
    #: how the NLP's figures of the quantity order: ``"max"`` when a larger figure is worse.
    #: The figure is the value itself but for the transmission angle, held as cos²μ
    #: (:meth:`to_figure`), which grows as μ shrinks.
    @property
    def figure_worst(self) -> str:
        return self.worst

    def to_figure(self, value: float) -> float:
        """A value (a bound) in the NLP's figure: the identity but where the NLP holds a
        monotone function of the value (cos²μ of an angle)."""
        return value

    def nlp_needs(self, sides) -> frozenset[str]:
        """What the NLP must hold exactly for the quantity to be bounded or pushed towards
        ``sides`` (``lower``: a lower bound, or maximised; ``upper``: an upper bound, or
        minimised) safely: each NLP form is exact, or conservative on one side, and a bound on
        the other side may ask for more (the ratio's mean needs exact hand-overs under a cap).
        Empty by default."""
        return frozenset()

    def track(self, builder, block) -> None:
        """Add the variables and rows one eccentricity block needs for this quantity's
        figures (a turn quantity's stationary points); none by default."""

    def figures(self, block, attained: bool = False) -> list:
        """The quantity's NLP figures in one eccentricity block (an
        :class:`~optdesign.solver.nlp.EccentricityBlock`): each conservative towards the
        quantity's natural side (:meth:`Quantity.natural_side`: never better than the exact
        figure it stands for), or with ``attained`` each a figure the design attains (never
        worse than the exact one, for a bound on the other side)."""
        raise NotImplementedError

    def sampled_value(self, view, eccentricity: float):
        """The value per screened design at one eccentricity, from the screening's sampling
        (a :class:`~optdesign.solver.screening.SampledView`): ranks designs, certifies none."""
        raise NotImplementedError

    def start_angles(self, design, eccentricity: float, sampled=None) -> dict:
        """Start values of the variables :meth:`track` adds for one block, by the suffix of
        their name (``angles`` and ``constant`` for a turn quantity's stationary points),
        from the exact evaluation of ``design``; none by default."""
        return {}

    def __repr__(self) -> str:
        return f"<quantity {self.name} [{self.unit}]>"


class TurnQuantity(Quantity):
    """The extremes over the turn of a per-angle expression, reduced to one value.

    A subclass writes :meth:`expression` (the components g(φ) whose maxima over the turn are
    wanted, from the mechanism's model) and :meth:`components` (the maxima, a CasADi or NumPy
    vector, to the figures whose ``worst`` is the quantity's value).
    """

    def expression(self, model: dict, phi, p: dict, count: int):
        """The components g(φ) (a list of SX scalars) from the mechanism's ``model``
        (``chain_expressions``: ``theta``, ``joints``; plus ``dtheta`` and ``ddtheta``)."""
        raise NotImplementedError

    def components(self, maxima, input_speed: float):
        """The figures whose worst is the value, from the components' maxima (a NumPy array
        or a CasADi column: only arithmetic)."""
        return maxima

    # ------------------------------------------------------------------ built once
    def function(self, mechanism, count: int, options: tuple = ()):
        """(φ, p) -> g and (φ, p) -> dg/dφ of ``mechanism`` (built once per count)."""
        return _functions(self, mechanism, count, options)

    def defined_for(self, design) -> bool:
        return self.function(design.model, design.count, design.option_key)[0].numel_out(0) > 0

    # ------------------------------------------------------------------ its forms
    def tracked(self, mechanism, count: int, options: tuple = ()):
        """(φ (one angle per component), p) -> (g_i(φ_i), dg_i/dφ(φ_i)): each component at
        an angle of its own, what the NLP holds at the components' stationary points."""
        return _tracked(self, mechanism, count, options)

    def from_kinematics(self, sampled: dict):
        """g on the exact evaluator's grid from its sampling of the kinematics (``theta``,
        ``dtheta``, ``ddtheta`` at the search grid, which starts at φ = 0), or None where g
        needs more (joints): saves sampling the design again."""
        return None

    def maxima(self, design, eccentricity: float = 1.0, sampled: dict | None = None):
        """Each component's maximum over the turn, exactly (:func:`turn_maxima`),
        remembered for the designs evaluated last (a solve's check and its next start).
        ``sampled``: the evaluation's sampling at this eccentricity, when at hand."""
        key = (self.name, design.mechanism, design.option_key,
               tuple(sorted(design.values.items())), float(eccentricity))
        known = _MAXIMA.get(key)
        if known is None:
            g, dg = self.function(design.model, design.count, design.option_key)
            breaks = sorted({float(b) % (2 * math.pi)
                             for b in design.breakpoints(eccentricity)})
            phi = search_grid(design, eccentricity)
            grid = self.from_kinematics(sampled) if sampled is not None else None
            if grid is not None and grid.shape[1] != phi.size:
                grid = None                 # sampled on another grid: sample it here
            known = keep(_MAXIMA, _MAXIMA_SIZE, key,
                         turn_maxima(g, dg, design.p_fixed(eccentricity), phi, breaks, grid))
        return known

    def exact(self, evaluation, eccentricity, ripple="midrange"):
        at = evaluation.at(eccentricity)
        maxima = self.maxima(evaluation.design, eccentricity, at.sampled).values
        figures = np.asarray(self.components(maxima, evaluation.input_speed), dtype=float)
        return self.worst_of(figures)

    def track(self, builder, block):
        """A free angle per component with g_i'(φ_i) = 0 (a stationary point, windowed like the
        peaks by the driver), so each component is held at its exact extreme; and, for a
        piecewise mechanism, the components at each side of its breakpoints, where an extreme
        has no stationary point (the pulse reducer's dead centres, fixed by the count)."""
        tracked = self.tracked(block.model, block.count, block.options)
        phi_q = builder.variable(f"phi_q_{self.name}_{block.tag}", tracked.size1_in(0))
        values, slopes = tracked(phi_q, block.pvec)
        builder.row(f"q_stationary_{self.name}[{block.tag}]", slopes)
        figures = [self.components(values, block.input_speed)]
        g, _ = self.function(block.model, block.count, block.options)
        for b in block.model.breakpoints({}, block.count):
            for side in (b - BREAK_STEP, b + BREAK_STEP):
                figures.append(self.components(g(side % (2 * math.pi), block.pvec),
                                               block.input_speed))
        block.tracked[self.name] = ca.vertcat(*figures)

    def figures(self, block, attained=False):
        """The components at their exact stationary points: exact, so both forms are one."""
        return [block.tracked[self.name]]

    def sampled_value(self, view, eccentricity):
        return self.sampled(view.turn(self, eccentricity), view.input_speed)

    def start_angles(self, design, eccentricity, sampled=None):
        maxima = self.maxima(design, eccentricity, sampled)
        return {"angles": maxima.angles, "constant": maxima.constant}

    def sampled(self, grid: np.ndarray, input_speed: float) -> np.ndarray:
        """The value from g sampled at (components, [designs,] angles): the screening's
        form, at most the exact one for a "max" quantity."""
        figures = np.asarray(self.components(grid.max(axis=-1), input_speed))
        return figures.max(axis=0) if self.worst == "max" else figures.min(axis=0)


#: the maxima of the designs evaluated last, oldest first
_MAXIMA: dict = {}
_MAXIMA_SIZE = 256


def forget_maxima() -> None:
    """Let go of every turn quantity's maxima kept (:data:`_MAXIMA`): the next search of any
    design's is made anew (:func:`optdesign.evaluation.figures.forget` calls it)."""
    _MAXIMA.clear()


@lru_cache(maxsize=256)
def _tracked(quantity: TurnQuantity, mechanism, count: int, options: tuple):
    g, dg = _functions(quantity, mechanism, count, options)
    m = g.numel_out(0)
    phi = ca.SX.sym("phi", m)
    pvec = ca.SX.sym("p", len(mechanism.lengths))
    values = [g.call([phi[i], pvec], True, False)[0][i] for i in range(m)]
    slopes = [dg.call([phi[i], pvec], True, False)[0][i] for i in range(m)]
    return ca.Function(f"tracked_{quantity.name}_{mechanism.name}_n{count}", [phi, pvec],
                       [ca.vertcat(*values), ca.vertcat(*slopes)])


@lru_cache(maxsize=256)
def _functions(quantity: TurnQuantity, mechanism, count: int, options: tuple):
    phi, pvec, p, model = mechanism.symbolic(count, options)
    g = ca.vertcat(*quantity.expression(dict(model), phi, p, count))
    name = f"{quantity.name}_{mechanism.name}_n{count}"
    return (ca.Function(name, [phi, pvec], [g]),
            ca.Function(f"d_{name}", [phi, pvec], [ca.jacobian(g, phi)]))

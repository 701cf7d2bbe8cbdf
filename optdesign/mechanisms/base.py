"""What every converting mechanism declares, so the commands run it without knowing which it is.

A mechanism turns the crank angle φ1 into the angles θ_k of its output members (rockers), one per
freewheel. Everything else (speeds, envelopes, ripple, the NLP, plots) is derived from the one
symbolic function it builds here, exactly as CasADi's own examples wrap a model once in a
``casadi.Function``.
"""
from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from functools import lru_cache
from typing import ClassVar, Mapping

import casadi as ca
import numpy as np

from optdesign.declarations import Key
from optdesign.envelope.sampled import STROKE_SIGNS  # noqa: F401  (a mechanism's strokes)
from optdesign.numerics import lanes_index, user_cache
from optdesign.numerics.angle_lanes import angle_lanes
from optdesign.numerics.lanes import Lanes

@dataclass(frozen=True)
class VariableSpec:
    """One design key of a mechanism."""

    name: str
    unit: str
    meaning: str
    integer: bool = False
    minimum: float = 0.0          # strict lower limit (lengths > 0; counts >= minimum)


@dataclass(frozen=True)
class OptionSpec:
    """A discrete modelling choice (assembly branch, layout reading), set under ``options:``."""

    name: str
    choices: tuple[str, ...]
    default: str
    meaning: str


class Mechanism(ABC):
    """Base class of the converting mechanisms found through :mod:`optdesign.mechanisms`."""

    name: ClassVar[str]
    source: ClassVar[str]
    variables: ClassVar[tuple[VariableSpec, ...]]
    count_variable: ClassVar[str]          # the integer key setting the number of freewheels
    regulating_variable: ClassVar[str]     # scaled by the eccentricity fraction e
    strokes: ClassVar[tuple[str, ...]] = ("forward", "reverse")
    options: ClassVar[tuple[OptionSpec, ...]] = ()

    # ----------------------------------------------------------------- declarations
    @property
    def lengths(self) -> tuple[str, ...]:
        """Names of the continuous design variables, in the order of the parameter vector."""
        return tuple(v.name for v in self.variables if not v.integer)

    def spec(self, name: str) -> VariableSpec:
        return next(v for v in self.variables if v.name == name)

    def default_options(self) -> dict[str, str]:
        return {o.name: o.default for o in self.options}

    # ----------------------------------------------------------------- the model
    @abstractmethod
    def chain_expressions(self, phi, p: Mapping[str, ca.SX], count: int,
                          options: Mapping[str, str]) -> dict:
        """Symbolic model at crank angle ``phi``.

        Returns a dict with ``theta`` (list of output-member angles, one per freewheel),
        ``cos_mu`` (list of cosines of the transmission angles; assembly needs |cos μ| <= 1),
        ``joints`` (name -> 2-vector, for drawings) and ``links`` (pairs of joint names).
        """

    def screening_expressions(self, phi, p: Mapping[str, ca.SX], count: int,
                              options: Mapping[str, str]) -> dict:
        """:meth:`chain_expressions` as the screening's speeds (:meth:`speeds`) are made
        from: the same unless a mechanism writes its chains there in another form, the same
        arithmetic up to rounding (the four-bar's without an atan2, so that its speeds may
        run on the compiled lanes, :mod:`optdesign.numerics.native_lanes`). The screening
        only ranks designs, each verified on the model itself before anything is claimed of
        it."""
        return self.chain_expressions(phi, p, count, options)

    #: the design ``optdesign init`` writes ({"input_speed": ..., "design": {...}}): one that
    #: assembles over the whole turn, its lengths to optimise freed over ranges that hold it;
    #: None: ``init`` refuses this mechanism
    starter: ClassVar[Mapping | None] = None

    #: the ``constraints:`` keys this mechanism owns beyond the general ones, each declared
    #: once here (type, default, unit, range, meaning): the loader reads them by these
    #: declarations into ``constraints.own``, the reference, the schema and ``init`` list them
    constraint_declarations: ClassVar[tuple[Key, ...]] = ()

    @property
    def constraint_keys(self) -> frozenset[str]:
        """The names of :attr:`constraint_declarations`."""
        return frozenset(k.name for k in self.constraint_declarations)

    def constraint_values(self, constraints) -> dict:
        """Each of this mechanism's own constraint keys at its value in ``constraints``
        (the loader's ``Constraints``), its declared default where the file gives none."""
        given = getattr(constraints, "own", None) or {}
        return {k.name: given.get(k.name, k.default) for k in self.constraint_declarations}

    def criteria(self, constraints, options: Mapping[str, str]) -> list:
        """This mechanism's own constraints (:class:`optdesign.quantities.criteria.LengthConstraint`),
        from the problem's ``constraints`` section and options."""
        return []

    def check_values(self, values: Mapping[str, float], count: int) -> None:
        """Raise :class:`ProblemError` for values no turn of the crank can make sense of."""

    def breakpoints(self, values: Mapping[str, float], count: int) -> tuple[float, ...]:
        """Crank angles where the speeds jump (piecewise mechanisms); none for smooth ones."""
        return ()

    # ----------------------------------------------------------------- built once
    @lru_cache(maxsize=64)
    def symbolic(self, count: int, options: tuple[tuple[str, str], ...] = (),
                 screening: bool = False) -> tuple:
        """(φ, p, p by name, model): :meth:`chain_expressions` on symbols of its own, with
        ``dtheta`` = dθ/dφ1 and ``ddtheta`` = d²θ/dφ1² (a column each) by algorithmic
        differentiation. Built once per count and shared by the functions made from it
        (:meth:`kinematics`, :meth:`joints`, the quantities'): each holds the nodes its own
        outputs need, so its arithmetic is what a model of its own gives. ``screening``: the
        same of :meth:`screening_expressions`, where a mechanism writes them otherwise (no
        ``ddtheta``: the speeds do not read it)."""
        opts = self.default_options() | dict(options)
        if screening and type(self).screening_expressions is Mechanism.screening_expressions:
            return self.symbolic(count, options)        # the same model: built once
        phi = ca.SX.sym("phi")
        pvec = ca.SX.sym("p", len(self.lengths))
        p = {name: pvec[i] for i, name in enumerate(self.lengths)}
        chains = self.screening_expressions if screening else self.chain_expressions
        model = dict(chains(phi, p, count, opts))
        model["dtheta"] = ca.jacobian(ca.vertcat(*model["theta"]), phi)
        if not screening:
            model["ddtheta"] = ca.jacobian(model["dtheta"], phi)
        return phi, pvec, p, model

    @lru_cache(maxsize=64)
    def kinematics(self, count: int, options: tuple[tuple[str, str], ...] = ()) -> ca.Function:
        """``casadi.Function`` (phi, p) -> (theta, dtheta, ddtheta, cos_mu).

        ``dtheta = dθ/dφ1`` and ``ddtheta = d²θ/dφ1²`` by algorithmic differentiation, so the
        rocker speed is ω_k = ω1 · dtheta_k (docs/formulation.md).
        """
        phi, pvec, _, model = self.symbolic(count, options)
        theta = ca.vertcat(*model["theta"])
        cos_mu = ca.vertcat(*model["cos_mu"])
        return ca.Function(f"{self.name}_n{count}", [phi, pvec],
                           [theta, model["dtheta"], model["ddtheta"], cos_mu],
                           ["phi", "p"], ["theta", "dtheta", "ddtheta", "cos_mu"])

    @lru_cache(maxsize=64)
    def packed(self, count: int, options: tuple[tuple[str, str], ...] = ()) -> ca.Function:
        """:meth:`kinematics` with its four outputs stacked in one column [θ; dθ; d²θ; cos μ]:
        one conversion to NumPy per call, for the exact evaluator's many single angles."""
        full = self.kinematics(count, options)
        phi = ca.SX.sym("phi")
        pvec = ca.SX.sym("p", len(self.lengths))
        return ca.Function(f"{self.name}_packed_n{count}", [phi, pvec],
                           [ca.vertcat(*full.call([phi, pvec], True, False))])

    @lru_cache(maxsize=64)
    def speeds(self, count: int, options: tuple[tuple[str, str], ...] = ()) -> ca.Function:
        """``casadi.Function`` (phi, p) -> (dtheta, cos_mu): the lean part of
        :meth:`kinematics` that screening thousands of designs needs, made from
        :meth:`screening_expressions` (the model's own chains unless a mechanism writes
        them otherwise there)."""
        phi, pvec, _, model = self.symbolic(count, options, screening=True)
        return ca.Function(f"{self.name}_speeds_n{count}", [phi, pvec],
                           [model["dtheta"], ca.vertcat(*model["cos_mu"])],
                           ["phi", "p"], ["dtheta", "cos_mu"])

    def kinematic_lanes(self, count: int, options: tuple[tuple[str, str], ...] = ()):
        """:meth:`kinematics` as NumPy lanes, for grids of many crank angles, cut at every
        atan2 (the four-bar's coupler angle φ2 of eq. (4) of Sharkov & Kalinin, each rocker
        angle θ_k): NumPy takes the angles from their legs between the stages, which, free
        of atan2, may run compiled (:mod:`optdesign.numerics.angle_lanes`). Made from their
        record where one is kept (:mod:`optdesign.numerics.lanes_index`: no function to
        write out and no stages to read back in a later process); once per
        ``OPTDESIGN_COMPILE`` in use (:meth:`lanes_made`)."""
        return self.lanes_made("kinematics", count, options, user_cache.mode())

    def speed_lanes(self, count: int, options: tuple[tuple[str, str], ...] = ()) -> Lanes:
        """:meth:`speeds` as NumPy lanes: thousands of (φ, p) columns in one call, for
        screening (raises :class:`NotImplementedError` where the function has instructions
        the lanes do not translate). Made from their record where one is kept
        (:mod:`optdesign.numerics.lanes_index`: no model of their own to build in a later
        process); once per ``OPTDESIGN_COMPILE`` in use (:meth:`lanes_made`)."""
        return self.lanes_made("speeds", count, options, user_cache.mode())

    @lru_cache(maxsize=128)
    def lanes_made(self, kind: str, count: int, options: tuple[tuple[str, str], ...],
                   mode: str):
        """The lanes of ``kind`` (``"kinematics"``, ``"speeds"``), made once per ``mode``
        (``OPTDESIGN_COMPILE``): lanes decide as they are made whether their loop runs
        compiled, so a process that turns the compiled code off (or on) after making some
        is given lanes made under its mode now, as its NLPs are (a benchmark that times
        both modes in one process)."""
        lanes, function = (angle_lanes, self.kinematics) if kind == "kinematics" else \
            (Lanes, self.speeds)
        return lanes_index.made(self, kind, count, options,
                                lambda: lanes(function(count, options)))

    def speeds_at_once(self, count: int, options: tuple[tuple[str, str], ...] = ()):
        """:meth:`speeds` evaluated at many (φ, p) columns in one call: the NumPy lanes, or
        CasADi's ``map`` for a function the lanes cannot read. Screening and the Monte Carlo
        both evaluate thousands of designs through this one door."""
        try:
            return self.speed_lanes(count, options)
        except NotImplementedError:
            fn = self.speeds(count, options)
            return lambda phi, p: fn.map(np.shape(p)[1])(phi, p)

    def chain(self, count: int, options: tuple[tuple[str, str], ...], k: int) -> ca.Function:
        """(phi, p) -> θ_k, dθ_k/dφ, d²θ_k/dφ², cos μ_k, d cos μ_k/dφ of chain k alone: an SX function
        holds only the nodes its outputs need, so a point that tracks one curve (a peak) does
        not pay for every chain."""
        return self._chains(count, options)[k]

    @lru_cache(maxsize=64)
    def _chains(self, count: int, options: tuple[tuple[str, str], ...]) -> tuple:
        """Every chain's function (:meth:`chain`), taken from one symbolic call of
        :meth:`kinematics` (each function holds chain k's nodes alone, as from a call of its
        own: the same arithmetic)."""
        full = self.kinematics(count, options)
        phi = ca.SX.sym("phi")
        pvec = ca.SX.sym("p", len(self.lengths))
        theta, dtheta, ddtheta, cos_mu = full.call([phi, pvec], True, False)
        return tuple(ca.Function(f"{self.name}_chain{k}_n{count}", [phi, pvec],
                                 [theta[k], dtheta[k], ddtheta[k], cos_mu[k],
                                  ca.jacobian(cos_mu[k], phi)],
                                 ["phi", "p"], ["theta", "dtheta", "ddtheta", "cos_mu",
                                                "dcos_mu"])
                     for k in range(count))

    @lru_cache(maxsize=64)
    def has_transmission_angle(self, count: int, options: tuple[tuple[str, str], ...]) -> bool:
        """False for a mechanism whose cos μ does not move with the crank (no rod-rocker
        pair, e.g. a slotted lever): its transmission angle needs no tracking. Read off the
        model :meth:`kinematics` is made from (a copy of its graph would cost a fifth of
        building it)."""
        phi, _, _, model = self.symbolic(count, options)
        return bool(ca.depends_on(ca.vertcat(*model["cos_mu"]), phi))

    @lru_cache(maxsize=256)
    def mapped(self, count: int, options: tuple[tuple[str, str], ...], n_points: int):
        """:meth:`kinematics` mapped over ``n_points`` crank angles (built once, then reused)."""
        return self.kinematics(count, options).map(n_points)

    def joint_forces(self, joints: dict, torques: np.ndarray) -> dict | None:
        """The forces in the joints (N) when each output member k delivers the torque
        ``torques[k]`` (N·m, per sample) to its freewheel, the links massless (a quasi-static
        analysis at each sample): ``{joint: force magnitude per sample}`` from the positions
        ``joints`` (mm, ``{name: (2, samples)}``); None where the mechanism has no such
        analysis."""
        return None

    @lru_cache(maxsize=64)
    def joints(self, count: int, options: tuple[tuple[str, str], ...] = ()):
        """``casadi.Function`` (phi, p) -> 2×J joint positions, and the names and links."""
        phi, pvec, _, model = self.symbolic(count, options)
        names = list(model["joints"])
        points = ca.horzcat(*[model["joints"][k] for k in names])
        return ca.Function(f"{self.name}_joints_n{count}", [phi, pvec], [points]), names, \
            list(model["links"])

"""What ``optdesign simulate`` reports: the recorded cycle's figures, its status and reason.

A :class:`SimulationResult` is written as ``dynamics.json`` and printed by ``--json``; when the
integration itself fails, :func:`failure_dict` is written in its place, with the same
``status`` and ``reason`` keys. Numbers that do not exist for a drive (the ripple of an output
that never moves) stay inf or NaN here; the JSON writer (:func:`optdesign.outputs.atomic.json_text`) makes
them null and lists them under ``non_finite``, and ``reason`` says why.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from optdesign.envelope.sampled import StrokeFigures
from optdesign.outputs.units import stamped

#: ``steady``: the cycle repeated (exit 0); ``not_steady``: ``cycles`` ran out first;
#: ``stalled``: the output never moves, or the crank cannot get round; ``failed``: the
#: integration broke down (all exit 1, with ``reason``).
STATUSES = ("steady", "not_steady", "stalled", "failed")


@dataclass
class SimulationResult:
    """The recorded cycle of the drive; speeds rad/s, times s, angles rad, powers W."""

    name: str
    mechanism: str
    freewheel: str
    crank: str
    method: str
    rtol: float
    atol: float
    status: str
    reason: str | None
    steady_residual: float
    cycles: int
    period_turns: int
    period_s: float
    omega_in_mean: float
    omega_out_mean: float
    dynamic: StrokeFigures
    kinematic: StrokeFigures
    eps_max: float
    power_in_w: float
    power_out_w: float
    steps: int
    events: int
    counters: dict
    wall_time_s: float
    instants: dict
    first_turn: dict
    switches: list
    labels: list
    trace: dict = field(repr=False, default_factory=dict)
    #: the freewheels' torques and the joints' forces over the cycle
    #: (:func:`optdesign.dynamics.loads.loads`)
    loads: dict = field(default_factory=dict)
    #: the natural frequencies beside the pulse frequency and its harmonics, and whether one
    #: lies near another (:func:`optdesign.dynamics.resonance.resonance`)
    resonance: dict = field(default_factory=dict)

    @property
    def steady(self) -> bool:
        """The cycle repeated and the drive turns its output (exit 0)."""
        return self.status == "steady"

    @property
    def cycle_time_s(self) -> float:
        """One crank turn, on average over the recorded cycle."""
        return self.period_s / self.period_turns

    @property
    def ratio(self) -> float:
        return self.omega_out_mean / self.omega_in_mean

    @property
    def power_balance(self) -> float:
        """(P_in - P_out)/P_in over the recorded cycle: 0 for lossless freewheels."""
        if self.power_in_w == 0:
            return float("nan")
        return (self.power_in_w - self.power_out_w) / self.power_in_w

    def to_dict(self) -> dict:
        """dynamics.json: the contract's keys, then ``schema_version`` and ``units``."""
        return stamped({
            "name": self.name, "mechanism": self.mechanism,
            "status": self.status, "reason": self.reason,
            "cycle_time_s": self.cycle_time_s,
            "period_turns": self.period_turns, "period_s": self.period_s,
            "omega_in_mean": self.omega_in_mean, "omega_out_mean": self.omega_out_mean,
            "ratio": self.ratio,
            "delta_dynamic": self.dynamic.delta, "delta_mean_dynamic": self.dynamic.delta_mean,
            "delta_kinematic": self.kinematic.delta,
            "delta_mean_kinematic": self.kinematic.delta_mean,
            "omega_out_max": self.dynamic.omega_max, "omega_out_min": self.dynamic.omega_min,
            "eps_max": self.eps_max,
            "power_in_w": self.power_in_w, "power_out_w": self.power_out_w,
            "power_balance": self.power_balance,
            "steps": self.steps, "events": self.events, "cycles": self.cycles,
            "steady": self.steady, "steady_residual": self.steady_residual,
            "instants": self.instants, "first_turn": self.first_turn,
            "switches": self.switches,
            "model": {"freewheel": self.freewheel, "crank": self.crank, "method": self.method,
                      "rtol": self.rtol, "atol": self.atol},
            "counters": self.counters, "wall_time_s": self.wall_time_s,
            "loads": self.loads,
            "resonance": self.resonance | (
                {"delta_ratio": self.dynamic.delta / self.kinematic.delta}
                if self.resonance and self.kinematic.delta else {}),
        })


def failure_dict(problem, section, method: str, status: str, reason: str) -> dict:
    """``dynamics.json`` of a run whose integration stopped before a cycle was recorded."""
    return stamped({"name": problem.name, "mechanism": problem.mechanism, "status": status,
                    "reason": reason, "steady": False,
                    "model": {"freewheel": section.freewheel, "crank": section.crank,
                              "method": method, "rtol": section.rtol, "atol": section.atol}})

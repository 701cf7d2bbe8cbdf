"""Simulate the drive turn by turn until the cycle repeats, then measure the steady cycle.

Steady-state criterion (stated once, used everywhere): the state at the start of consecutive
crank turns (φ = 2π·m) repeats, i.e. over one turn

- the crank speed φ̇ and the output speed ψ̇ change by at most ``steady_tol``·ω1,
- every freewheel torque λ_k·ε_k changes by at most ``steady_tol``·T_ref (T_ref the largest of
  the mean load and the peak freewheel torque of the turn), with the same freewheels engaged
  and the output in the same state (moving, or held at rest by its load),
- and the turn time changes by at most ``steady_tol`` of itself.

The turn after the first repeat is recorded densely and measured. Angles are re-based at every
turn (φ ← φ - 2π, ψ ← 0, references shifted with ψ) so the relative angles ε_k, which are tiny
for stiff freewheels, are never the difference of two large numbers.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..design import Design
from ..envelope import StrokeFigures
from .integrator import Integrator, Trace
from .model import TWO_PI, DriveModel, Mode
from .section import DynamicsSection


@dataclass
class SimulationResult:
    """The steady cycle of the drive; speeds rad/s, times s, angles rad, powers W."""

    name: str
    mechanism: str
    freewheel: str
    crank: str
    method: str
    rtol: float
    atol: float
    steady: bool
    steady_residual: float
    cycles: int
    cycle_time_s: float
    omega_in_mean: float
    omega_out_mean: float
    ratio: float
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

    @property
    def power_balance(self) -> float:
        """(P_in - P_out)/P_in over the steady cycle: 0 for lossless freewheels."""
        if self.power_in_w == 0:
            return float("nan")
        return (self.power_in_w - self.power_out_w) / self.power_in_w

    def to_dict(self) -> dict:
        return {
            "name": self.name, "mechanism": self.mechanism,
            "cycle_time_s": self.cycle_time_s,
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
        }


def simulate(problem, section: DynamicsSection | None = None, method: str | None = None,
             samples: int = 2000) -> SimulationResult:
    """Run the ``dynamics:`` section of ``problem`` to its steady cycle.

    Parameters
    ----------
    problem : Problem
        A loaded problem; its design is evaluated at its fixed/initial values.
    section : DynamicsSection, optional
        Overrides ``problem.sections["dynamics"]``.
    method : str, optional
        Overrides the section's integrator (``Radau``, ``BDF``, ``LSODA``, ``RK45``).
    samples : int
        Dense-output samples per turn of the recorded steady cycle (extremes of ψ̇).
    """
    from ..exact import exact_figures

    section = section or problem.sections["dynamics"]
    method = method or section.method
    design = Design.from_problem(problem)
    design.check_assembly()
    model = DriveModel(design, problem.stroke, problem.input_speed, section, problem.source)
    integ = Integrator(model, method, section.rtol, section.atol)
    clock = time.perf_counter()
    approach = _to_steady(model, integ, section)
    cycle = _record_cycle(model, integ, approach, samples)
    wall = time.perf_counter() - clock
    kinematic, _ = exact_figures(design, problem.stroke, problem.input_speed)
    return _result(problem, section, method, model, integ, approach, cycle, kinematic, wall)


@dataclass
class _Approach:
    """The turns run until the cycle repeats: where the recorded turn starts."""

    y: np.ndarray
    mode: Mode
    lead: int
    turns: int
    steady: bool
    residual: float
    first_turn: dict | None


@dataclass
class _Cycle:
    """The recorded steady turn: the trace and what it sums to."""

    start: np.ndarray
    y_end: np.ndarray
    events: list
    period: float
    t: np.ndarray
    ys: np.ndarray
    eps: np.ndarray
    engaged: np.ndarray


def _to_steady(model: DriveModel, integ: Integrator, section) -> _Approach:
    """Whole turns until two consecutive turns agree to ``steady_tol`` (or ``cycles`` - 1)."""
    y, mode = _initial_state(model)
    lead = int(np.argmax(mode.engaged))
    previous, residual, steady, turns, first_turn = None, np.inf, False, 0, None
    while turns < section.cycles - 1:          # the last allowed turn is the recorded one
        y_end, mode, events, period = integ.run_turn(y, mode)
        turns += 1
        if first_turn is None:
            first_turn = _first_turn(events, model.labels(), lead)
        y, mode = _rebase(model, y_end, mode)
        signature = _signature(model, y, mode, period)
        if previous is not None:
            residual = _change(previous, signature, model, events)
            if residual <= section.steady_tol:
                steady = True
                break
        previous = signature
    return _Approach(y, mode, lead, turns, steady, residual, first_turn)


def _record_cycle(model: DriveModel, integ: Integrator, approach: _Approach,
                  samples: int) -> _Cycle:
    """One more turn with dense output: the steady cycle as recorded."""
    trace = Trace()
    start = approach.y.copy()
    y_end, _, events, period = integ.run_turn(approach.y, approach.mode, trace, samples)
    approach.turns += 1
    ys = np.asarray(trace.y).T
    # an output at rest stopped at ψ̇ = -η·ω1 (the event's offset): show it at 0
    ys[3] = np.where((ys[3] < 0) & (ys[3] > -1e-9 * model.input_speed), 0.0, ys[3])
    return _Cycle(start, y_end, events, period, np.asarray(trace.t), ys,
                  np.asarray(trace.eps).T, np.asarray(trace.engaged).T)


def _result(problem, section, method, model, integ, approach: _Approach, cycle: _Cycle,
            kinematic, wall: float) -> SimulationResult:
    """The figures of the recorded cycle (dynamic δ, ratio, power balance, instants)."""
    ys, start, y_end, period, events = cycle.ys, cycle.start, cycle.y_end, cycle.period, \
        cycle.events
    omega_in_mean = TWO_PI / period
    omega_out_mean = (y_end[2] - start[2]) / period
    dynamic = StrokeFigures.from_extremes(ys[3].max(), ys[3].min(), omega_out_mean,
                                          omega_in_mean)
    eps_engaged = np.where(cycle.engaged, cycle.eps, -np.inf)
    eps_max = max([float(eps_engaged.max())] + [e.eps for e in events if e.kind == "eps_max"])
    c = integ.counters
    labels = model.labels()
    return SimulationResult(
        name=problem.name, mechanism=problem.mechanism, freewheel=section.freewheel,
        crank=section.crank, method=method, rtol=section.rtol, atol=section.atol,
        steady=approach.steady, steady_residual=float(approach.residual),
        cycles=approach.turns, cycle_time_s=float(period),
        omega_in_mean=float(omega_in_mean), omega_out_mean=float(omega_out_mean),
        ratio=float(omega_out_mean / omega_in_mean),
        dynamic=dynamic, kinematic=kinematic, eps_max=eps_max,
        power_in_w=float((y_end[4] - start[4]) / period),
        power_out_w=float((y_end[5] - start[5]) / period),
        steps=c.steps, events=c.events,
        counters={"nfev": c.nfev, "njev": c.njev, "nlu": c.nlu, "segments": c.segments,
                  "steady_cycle_events": sum(e.kind != "eps_max" for e in events)},
        wall_time_s=wall, instants=_instants(events, period, labels),
        first_turn=approach.first_turn or _first_turn(events, labels, approach.lead),
        switches=[{"t_s": float(e.t), "phi_deg": float(np.degrees(e.phi)), "kind": e.kind,
                   "freewheel": labels[e.wheel] if e.wheel >= 0 else None, "eps": e.eps}
                  for e in events],
        labels=labels,
        trace={"t": cycle.t, "phi": ys[0], "omega_in": ys[1], "psi": ys[2] - start[2],
               "omega_out": ys[3], "eps": cycle.eps, "engaged": cycle.engaged,
               "holder_speed": _holder_speeds(model, ys)})


def _initial_state(model: DriveModel) -> tuple[np.ndarray, Mode]:
    """The paper's start: crank at φ = 0 turning at ω1, the leading freewheel just closed
    (ε = 0) and the output turning with its holder (at rest at a dead centre)."""
    w = model.input_speed
    u, du, _ = model.holders(0.0)
    lead = int(np.argmax(du))
    engaged = np.zeros(model.size, bool)
    engaged[lead] = True
    offset = np.where(engaged, u, 0.0)
    speed = max(float(du[lead]), 0.0) * w
    stuck = speed == 0.0 and model.load.mean > 0
    return np.array([0.0, w, 0.0, speed, 0.0, 0.0]), Mode(engaged, offset, stuck)


def _rebase(model: DriveModel, y: np.ndarray, mode: Mode) -> tuple[np.ndarray, Mode]:
    """φ ← φ - 2π, ψ ← 0, work counters ← 0, references shifted so that every ε_k is kept."""
    u_old = model.holders(y[0])[0].copy()
    y = y.copy()
    shift = y[2]
    y[0] -= TWO_PI
    u_new = model.holders(y[0])[0]
    offset = mode.offset + (u_new - u_old) + shift
    model.psi_origin += shift
    y[2] = 0.0
    y[4] = y[5] = 0.0
    return y, Mode(mode.engaged.copy(), offset, mode.stuck)


def _signature(model, y, mode, period):
    _, _, _, eps, _, _ = model.forces(y, mode)
    torque = np.where(mode.engaged, model.stiffness * eps, 0.0)
    return y[1], y[3], torque, np.append(mode.engaged, mode.stuck), period


def _change(a, b, model, events) -> float:
    """Largest relative change of the turn-start state (the criterion in the module doc)."""
    if not np.array_equal(a[3], b[3]):
        return np.inf
    peaks = [model.stiffness[e.wheel] * e.eps for e in events if e.kind == "eps_max"]
    t_ref = max([model.load.mean, 1e-12] + peaks)
    w = model.input_speed
    return float(max(abs(a[0] - b[0]) / w, abs(a[1] - b[1]) / w,
                     np.max(np.abs(a[2] - b[2]), initial=0.0) / t_ref,
                     abs(a[4] - b[4]) / b[4]))


def _holder_speeds(model, ys) -> np.ndarray:
    out = np.empty((model.size, ys.shape[1]))
    for j in range(ys.shape[1]):
        out[:, j] = model.holders(ys[0, j])[1] * ys[1, j]
    return out


def _instants(events, period, labels) -> dict:
    """The paper's instants, from the first engagement of the steady turn (t = 0 there):
    t1 end of jamming (ε max), t2 release (start of the overrun), t3 next engagement."""
    first = next((e for e in events if e.kind == "engage"), None)
    if first is None:
        return {"note": "no freewheel engages in the steady cycle"}
    # events before the first engagement belong, in the periodic cycle, one turn later
    rel = sorted(((e.t - first.t) % period, e) for e in events)
    wheel = first.wheel
    t1 = next((t for t, e in rel if e.kind == "eps_max" and e.wheel == wheel), None)
    t2 = next((t for t, e in rel if e.kind == "release" and e.wheel == wheel), None)
    t3 = next((t for t, e in rel if e.kind == "engage" and t2 is not None and t > t2), None)
    if t3 is None and t2 is not None:
        t3 = period                       # only this engagement per turn: it comes back
    return {"freewheel": labels[wheel], "t0_in_turn_s": float(first.t),
            "t1_s": t1 and float(t1), "t2_s": t2 and float(t2), "t3_s": t3 and float(t3)}


def _first_turn(events, labels, wheel: int) -> dict:
    """The same instants in the first turn from the start state, t = 0 at φ = 0 where
    freewheel ``wheel`` has just closed: the paper's single computed cycle. t1, t2 are that
    freewheel's ε maximum and release, t3 the next closing of any freewheel after t2."""
    def first(kind, after=-1.0, own=True):
        return next((e for e in events if e.kind == kind and e.t > after
                     and (e.wheel == wheel) == own), None)

    t1, t2 = first("eps_max"), first("release")
    t3 = None
    if t2 is not None:
        t3 = first("engage", t2.t, own=False) or first("engage", t2.t)
        if t3 is not None and labels[t3.wheel] == labels[wheel] and len(labels) > 1:
            t3 = min((e for e in events if e.kind == "engage" and e.t > t2.t),
                     key=lambda e: e.t)
    return {"freewheel": labels[wheel], "t1_s": t1 and float(t1.t),
            "t2_s": t2 and float(t2.t), "t3_s": t3 and float(t3.t),
            "t3_freewheel": t3 and labels[t3.wheel],
            "eps_max": t1 and float(t1.eps)}

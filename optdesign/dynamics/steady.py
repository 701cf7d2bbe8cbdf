"""Simulate the drive turn by turn until the motion repeats, then measure the recorded cycle.

Steady-state criterion (stated once, used everywhere): the state at the start of a crank turn
(φ = 2π·m) repeats after p turns, p = 1 .. ``LONGEST_PERIOD`` (the smallest that does), i.e.

- the crank speed φ̇ and the output speed ψ̇ agree to ``steady_tol``·ω1,
- every freewheel torque λ_k·ε_k agrees to ``steady_tol``·T_ref (T_ref the largest of the mean
  load and the peak freewheel torque of the turn), with the same freewheels engaged and the
  output in the same state (moving, or held at rest by its load); for the ``composite`` model
  the gap ε of a released freewheel is state too (it must close before the spring pushes
  again), and counts as the torque λ·ε,
- and the turn time agrees to ``steady_tol`` of itself.

A period of p > 1 turns is a real limit cycle, not a tolerance artefact: the pulse reducer's
composite freewheel at λ = 1e4 closes once just before and once just after φ = 0 in
alternate turns. The p turns after the repeat are recorded densely and measured. A ratchet
drive whose output stands still for a whole turn has stalled (:mod:`.verdict`). Angles are
re-based at every turn (φ ← φ - 2π, ψ ← 0, references shifted with ψ) so the relative angles
ε_k, tiny for stiff freewheels, are never the difference of two large numbers.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from optdesign.dynamics.instants import first_turn_instants, steady_instants
from optdesign.dynamics.integrator import Integrator, Trace
from optdesign.dynamics.loads import loads
from optdesign.dynamics.model import DriveModel, Mode, TWO_PI
from optdesign.dynamics.resonance import resonance
from optdesign.dynamics.result import SimulationResult
from optdesign.dynamics.section import DynamicsSection, check_motor_speed
from optdesign.dynamics.verdict import LONGEST_PERIOD, held_whole_turn, judge
from optdesign.envelope.exact import exact_figures
from optdesign.envelope.sampled import StrokeFigures
from optdesign.evaluation.design import Design


def simulate(problem, section: DynamicsSection | None = None, method: str | None = None,
             samples: int = 2000, progress=None) -> SimulationResult:
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
        Dense-output samples per turn of the recorded cycle (extremes of ψ̇).
    progress : callable, optional
        Called once per crank turn integrated on the way to the steady cycle.

    Raises
    ------
    SolveError
        The integration broke down; :class:`~optdesign.dynamics.integrator.StallError` when
        the crank cannot get round.
    """
    section = section or problem.sections["dynamics"]
    check_motor_speed(section, problem)
    method = method or section.method
    design = Design.from_problem(problem)
    design.check_assembly()
    model = DriveModel(design, problem.stroke, problem.input_speed, section, problem.source)
    integ = Integrator(model, method, section.rtol, section.atol)
    clock = time.perf_counter()
    approach = _to_steady(model, integ, section, progress)
    cycle = _record_cycle(model, integ, approach, samples)
    for _ in range(approach.period if progress else 0):     # the recorded cycle's turns
        progress()
    wall = time.perf_counter() - clock
    kinematic, _ = exact_figures(design, problem.stroke, problem.input_speed)
    result = _result(problem, section, method, model, integ, approach, cycle, kinematic, wall)
    result.loads, series = loads(design, model, result.trace, section.reduction,
                                 result.switches)
    result.trace |= series
    return result


@dataclass
class _Approach:
    """The turns run until the motion repeats: where the recorded cycle starts."""

    y: np.ndarray
    mode: Mode
    lead: int
    turns: int
    steady: bool
    stalled: bool
    period: int                    # turns of the repeating motion (1 when not steady)
    residual: float
    residuals: list = field(default_factory=list)     # one-turn residual of every turn
    impact: float = 0.0            # largest relative speed ε̇ at a closing, any turn
    first_events: list = field(default_factory=list)  # the events of the first turn


@dataclass
class _Cycle:
    """The recorded cycle (``turns`` crank turns): the trace and what it sums to."""

    start: np.ndarray
    y_end: np.ndarray
    events: list
    period: float
    turns: int
    stalled: bool
    t: np.ndarray
    ys: np.ndarray
    eps: np.ndarray
    engaged: np.ndarray


def _to_steady(model: DriveModel, integ: Integrator, section, progress=None) -> _Approach:
    """Whole turns until the turn-start state repeats after 1 .. LONGEST_PERIOD turns, the
    output stalls, or ``cycles`` - 1 turns have run (the last allowed turn is recorded)."""
    y, mode = _initial_state(model)
    run = _Approach(y, mode, int(np.argmax(mode.engaged)), 0, False, False, 1, np.inf)
    history: list = []               # (signature, T_ref) of the last LONGEST_PERIOD turns
    while run.turns < section.cycles - 1:
        stuck = run.mode.stuck
        y_end, mode, events, period = integ.run_turn(run.y, run.mode)
        run.turns += 1
        if progress:
            progress()
        run.impact = max([run.impact] + [abs(e.speed) for e in events if e.kind == "engage"])
        if run.turns == 1:
            run.first_events = events
        run.y, run.mode = _rebase(model, y_end, mode)
        if held_whole_turn(model, events, stuck, mode.stuck):
            run.stalled = True
            break
        signature = _signature(model, run.y, run.mode, period)
        t_ref = _torque_scale(model, events)
        changes = [_change(old, signature, max(ref, t_ref), model.input_speed)
                   for old, ref in reversed(history)]       # 1, 2, ... turns back
        if changes:
            run.residual = changes[0]
            run.residuals.append(changes[0])
        repeat = next((p for p, change in enumerate(changes, 1)
                       if change <= section.steady_tol), None)
        if repeat is not None:
            run.steady, run.period, run.residual = True, repeat, changes[repeat - 1]
            break
        history = (history + [(signature, t_ref)])[-LONGEST_PERIOD:]
    return run


def _record_cycle(model: DriveModel, integ: Integrator, run: _Approach,
                  samples: int) -> _Cycle:
    """``run.period`` more turns with dense output, joined into one record: the cycle."""
    t, y, mode = [], run.y.copy(), run.mode
    start = y.copy()
    rows, eps, engaged, events = [], [], [], []
    offset = np.zeros(6)                 # what the re-basing took off: φ, ψ and the work
    elapsed, stalled = 0.0, run.stalled
    for turn in range(run.period):
        trace = Trace()
        stuck = mode.stuck
        y_end, mode, turn_events, duration = integ.run_turn(y, mode, trace, samples)
        run.turns += 1
        run.impact = max([run.impact] + [abs(e.speed) for e in turn_events
                                         if e.kind == "engage"])
        stalled = stalled or held_whole_turn(model, turn_events, stuck, mode.stuck)
        t.append(np.asarray(trace.t) + elapsed)
        rows.append(np.asarray(trace.y).T + offset[:, None])
        eps.append(np.asarray(trace.eps).T)
        engaged.append(np.asarray(trace.engaged).T)
        events += [replace(e, t=e.t + elapsed, phi=e.phi + offset[0]) for e in turn_events]
        elapsed += duration
        last = y_end + offset
        if turn < run.period - 1:
            offset = offset + np.array([TWO_PI, 0.0, y_end[2], 0.0, y_end[4], y_end[5]])
            y, mode = _rebase(model, y_end, mode)
    ys = np.hstack(rows)
    # an output at rest stopped at ψ̇ = -η·ω1 (the event's offset): show it at 0
    ys[3] = np.where((ys[3] < 0) & (ys[3] > -1e-9 * model.input_speed), 0.0, ys[3])
    return _Cycle(start, last, events, elapsed, run.period, stalled, np.concatenate(t), ys,
                  np.hstack(eps), np.hstack(engaged))


def _result(problem, section, method, model, integ, run: _Approach, cycle: _Cycle,
            kinematic, wall: float) -> SimulationResult:
    """The figures of the recorded cycle (dynamic δ, ratio, power balance, instants)."""
    ys, start, y_end, period, events = cycle.ys, cycle.start, cycle.y_end, cycle.period, \
        cycle.events
    omega_in_mean = TWO_PI * cycle.turns / period
    omega_out_mean = (y_end[2] - start[2]) / period
    dynamic = StrokeFigures.from_extremes(ys[3].max(), ys[3].min(), omega_out_mean,
                                          omega_in_mean)
    eps_engaged = np.where(cycle.engaged, cycle.eps, -np.inf)
    eps_max = max([float(eps_engaged.max())] + [e.eps for e in events if e.kind == "eps_max"])
    verdict = judge(model, section, run.turns, run.steady, cycle.stalled, run.residuals,
                    events, run.impact)
    c = integ.counters
    labels = model.labels()
    band = 10.0 * integ.eta
    return SimulationResult(
        name=problem.name, mechanism=problem.mechanism, freewheel=section.freewheel,
        crank=section.crank, method=method, rtol=section.rtol, atol=section.atol,
        status=verdict.status, reason=verdict.reason,
        steady_residual=float(run.residual), cycles=run.turns,
        period_turns=cycle.turns, period_s=float(period),
        omega_in_mean=float(omega_in_mean), omega_out_mean=float(omega_out_mean),
        dynamic=dynamic, kinematic=kinematic, eps_max=eps_max,
        power_in_w=float((y_end[4] - start[4]) / period),
        power_out_w=float((y_end[5] - start[5]) / period),
        steps=c.steps, events=c.events,
        counters={"nfev": c.nfev, "njev": c.njev, "nlu": c.nlu, "segments": c.segments,
                  "fallbacks": c.fallbacks,
                  "steady_cycle_events": sum(e.kind != "eps_max" for e in events)},
        wall_time_s=wall, instants=steady_instants(events, period, labels, band),
        first_turn=first_turn_instants(run.first_events or events, labels, run.lead, band),
        switches=[{"t_s": float(e.t), "phi_deg": float(np.degrees(e.phi)), "kind": e.kind,
                   "freewheel": labels[e.wheel] if e.wheel >= 0 else None, "eps": e.eps}
                  for e in events],
        labels=labels,
        trace={"t": cycle.t, "phi": ys[0], "omega_in": ys[1], "psi": ys[2] - start[2],
               "omega_out": ys[3], "eps": cycle.eps, "engaged": cycle.engaged,
               "holder_speed": _holder_speeds(model, ys)},
        resonance=_resonance(problem, section, float(omega_in_mean)))


def _resonance(problem, section: DynamicsSection, omega_in: float) -> dict:
    """:func:`optdesign.dynamics.resonance.resonance` of the drive at its mean crank speed:
    the pulses per turn are the output envelope's hand-overs (one per driving run), λ the
    freewheels' mean stiffness."""
    from optdesign.evaluation.figures import evaluate

    design = Design.from_problem(problem)
    runs = evaluate(design, problem.stroke, omega_in, (1.0,)).per_e[0].runs
    stiffness = float(np.mean(section.stiffness_per_phase(design.count)))
    return resonance(section.I1, section.I2, stiffness, max(1, len(runs)), omega_in)


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
    """The turn-start state the criterion compares: crank and output speeds, freewheel
    torques (a composite freewheel's gap too), the discrete mode, the turn time."""
    _, _, _, eps, _, _ = model.forces(y, mode)
    state = mode.engaged | model.composite
    torque = np.where(state, model.stiffness * eps, 0.0)
    return y[1], y[3], torque, np.append(mode.engaged, mode.stuck), period


def _torque_scale(model, events) -> float:
    """T_ref of a turn: the mean load or the largest freewheel torque peak, if larger."""
    peaks = [model.stiffness[e.wheel] * e.eps for e in events if e.kind == "eps_max"]
    return max([model.load.mean, 1e-12] + peaks)


def _change(a, b, t_ref: float, w: float) -> float:
    """Largest relative change between two turn-start states (the module's criterion)."""
    if not np.array_equal(a[3], b[3]):
        return np.inf
    return float(max(abs(a[0] - b[0]) / w, abs(a[1] - b[1]) / w,
                     np.max(np.abs(a[2] - b[2]), initial=0.0) / t_ref,
                     abs(a[4] - b[4]) / b[4]))


def _holder_speeds(model, ys) -> np.ndarray:
    out = np.empty((model.size, ys.shape[1]))
    for j in range(ys.shape[1]):
        out[:, j] = model.holders(ys[0, j])[1] * ys[1, j]
    return out

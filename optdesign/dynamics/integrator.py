"""Event-driven integration of the switching drive: one ``solve_ivp`` call per smooth segment.

The right-hand side is smooth only between switches, so every engagement and release of a
freewheel, every mechanism breakpoint (where u_k'' jumps) and every crank-turn boundary is a
terminal event located by the integrator's root finder on its dense output; the integration
restarts from the located state with the new mode. An implicit method (Radau IIA order 5 by
default, or BDF/LSODA) takes the stiff spring modes √(λ/I) in its stride with the analytic
Jacobian; RK45 is offered only to show what an explicit method costs here.

Switching rules (see :mod:`optdesign.dynamics.model`):

- engaged freewheel k: released when its torque λ_k·ε_k + c_k·ε̇_k falls through 0;
- released, ``ratchet``: engaged when the relative speed ε̇_k rises through 0 (reference reset);
- released, ``composite``: engaged when ε and the torque λ·ε + c·ε̇ are both positive again
  (undamped: ε rises through 0, Φ has caught up with ψ; damped, a unilateral Kelvin-Voigt
  contact: it may also close before ε returns to 0, once the spring-damper pushes again);
- output moving: it stops when ψ̇ falls to 0 and the freewheels cannot overcome the load;
  output at rest: it starts when Σ λ_k·ε_k rises above T_c;
- a release with ε̇_k ≈ 0 whose free flight would end within ``GRAZE`` of a turn is a graze:
  the freewheel stays engaged (reference reset to ε_k = 0), instead of a burst of zero-length
  segments (chattering).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp

from optdesign.dynamics.model import DriveModel, Mode, TWO_PI
from optdesign.errors import SolveError

IMPLICIT = ("Radau", "BDF", "LSODA")
GRAZE = 1e-9            # free flights shorter than this fraction of a turn are grazes
MAX_ZERO_SEGMENTS = 50  # consecutive zero-length segments before declaring chattering
STALL_TURNS = 50.0      # a segment longer than this many nominal turn times: the crank stalls
STOP_TOL = 1e-12        # rad: a segment ending this close to its stop angle has reached it


class StallError(SolveError):
    """The crank cannot complete its turn: the motor does not overcome the reaction."""


@dataclass
class Event:
    """One located switch: ``kind`` engage | release | eps_max | graze | output_stops |
    output_starts, freewheel index (-1 for the output), ε and the relative speed ε̇ there."""

    t: float
    phi: float
    kind: str
    wheel: int
    eps: float = 0.0
    speed: float = 0.0


@dataclass
class Counters:
    steps: int = 0           # accepted integrator steps
    nfev: int = 0
    njev: int = 0
    nlu: int = 0
    events: int = 0          # engagements + releases + grazes (terminal switches)
    segments: int = 0
    fallbacks: int = 0       # segments redone with Radau (see Integrator._segment)


@dataclass
class Trace:
    """Dense record of one stretch of simulation (for the steady cycle's figures)."""

    t: list = field(default_factory=list)
    y: list = field(default_factory=list)
    eps: list = field(default_factory=list)
    engaged: list = field(default_factory=list)


class Integrator:
    """Advances the drive from stop to stop (see the module docstring)."""

    def __init__(self, model: DriveModel, method: str = "Radau", rtol: float = 1e-8,
                 atol: float = 1e-10):
        self.model = model
        self.method = method
        self.rtol = rtol
        w = model.input_speed
        work = TWO_PI * max(model.a, model.load.mean, 1e-12)      # ~ energy of one turn
        self.atol = np.array([atol, atol * w, atol, atol * w, rtol * work, rtol * work])
        self.turn_time = TWO_PI / w
        # switching functions cross ±eta, not 0, so that a restart exactly on ε = 0 is not
        # found again as a root at the restart instant (brentq returns an end that is a root)
        self.eta = 1e-3 * atol
        self.counters = Counters()

    # ------------------------------------------------------------------ one crank turn
    def run_turn(self, y0: np.ndarray, mode: Mode, trace: Trace | None = None,
                 samples: int = 0) -> tuple[np.ndarray, Mode, list[Event], float]:
        """Integrate from φ = y0[0] (a multiple of 2π, or 0) to φ + 2π; return the end state,
        the mode, the events and the duration. ``samples`` points per turn go to ``trace``."""
        t = 0.0
        y = np.array(y0, dtype=float)
        phi_end = y[0] + TWO_PI
        events: list[Event] = []
        zero_run = 0
        while True:
            stop = self._next_stop(y[0], phi_end)
            seg_events, kinds = self._event_functions(mode, stop)
            sol = self._segment(t, y, mode, seg_events, trace is not None)
            for j, (kind, wheel) in enumerate(kinds):   # ε maxima: non-terminal, recorded
                if kind == "eps_max":
                    for te, ye in zip(sol.t_events[j], sol.y_events[j]):
                        if _repeats(events, te, wheel):   # found again on a restart there
                            continue
                        events.append(Event(te, ye[0], kind, wheel,
                                            float(self.model.forces(ye, mode)[3][wheel])))
            t_new = sol.t[-1]
            if trace is not None:
                self._record(trace, sol, mode, max(samples, 2) * (t_new - t) / self.turn_time)
            zero_run = zero_run + 1 if t_new - t <= 1e-12 * self.turn_time else 0
            if zero_run > MAX_ZERO_SEGMENTS:
                raise SolveError(f"freewheels chatter at t = {t:.6g} s: {zero_run} switches "
                                 "without progress (try a tighter rtol)")
            y_start, (t, y) = y, (t_new, sol.y[:, -1].copy())
            fired = _fired(sol, seg_events, kinds, y_start, y)
            reached = ("stop", -1) in fired or y[0] >= stop - STOP_TOL
            if reached:
                y[0] = stop                      # exact, so the next turn starts on 2π·m
            for kind, wheel in sorted(fired, key=lambda f: f[0].startswith("output")):
                if kind != "stop":
                    mode = self._switch(kind, wheel, y, mode, t, events)
            if reached and stop >= phi_end - STOP_TOL:
                return y, mode, events, t
            if y[0] > phi_end + STOP_TOL:           # a guard: the turn's end was stepped over
                raise SolveError(f"integration passed the end of the turn at t = {t:.6g} s "
                                 f"without stopping there")

    def _segment(self, t: float, y: np.ndarray, mode: Mode, seg_events, dense: bool):
        """One ``solve_ivp`` call from (t, y) in ``mode`` to its first terminal event; a
        failure names the instant and the crank angle, a crank that never gets round is a
        :class:`StallError`.

        BDF's and LSODA's dense output is a polynomial through the step's end that only
        approximates its start; a switching function that starts a segment next to its root
        (a restart on a switch) can then show one sign at the step's start and the other on
        the interpolant there, and scipy's root bracketing fails ("f(a) and f(b) must have
        different signs"). Such a segment is redone with Radau, whose collocation polynomial
        passes through both ends (counted in ``fallbacks``)."""
        where = f"t = {t:.6g} s, crank angle {np.degrees(y[0]) % 360:.3f} deg"
        try:
            sol = self._solve(self.method, t, y, mode, seg_events, dense)
        except ValueError as exc:
            if "different signs" not in str(exc) or self.method == "Radau":
                raise SolveError(f"integration failed after {where}: {exc}") from None
            self.counters.fallbacks += 1
            try:
                sol = self._solve("Radau", t, y, mode, seg_events, dense)
            except (ValueError, FloatingPointError, ZeroDivisionError) as again:
                raise SolveError(f"integration failed after {where}: {again}") from None
        except (FloatingPointError, ZeroDivisionError) as exc:
            raise SolveError(f"integration failed after {where}: {exc}") from None
        self._count(sol)
        if sol.status == -1:
            raise SolveError(f"integration failed after {where}: {sol.message}")
        if not np.all(np.isfinite(sol.y[:, -1])):
            raise SolveError(f"integration failed after {where}: the state is not finite")
        if sol.status == 0:
            end = sol.y[:, -1]
            raise StallError(
                f"the crank stalls: it did not get round within {STALL_TURNS:g} nominal turn "
                f"times and stands at {np.degrees(end[0]) % 360:.1f} deg, turning at "
                f"{end[1]:.3g} rad/s (the motor's {self.model.a:g} N·m does not overcome the "
                f"freewheels' reaction)")
        return sol

    def _solve(self, method: str, t: float, y: np.ndarray, mode: Mode, seg_events, dense):
        return solve_ivp(lambda _t, _y: self.model.rhs(_y, mode),
                         (t, t + STALL_TURNS * self.turn_time), y, method=method,
                         events=seg_events, rtol=self.rtol, atol=self.atol,
                         dense_output=dense,
                         **({"jac": lambda _t, _y: self.model.jacobian(_y, mode)}
                            if method in IMPLICIT else {}))

    def _next_stop(self, phi: float, phi_end: float) -> float:
        turns = np.floor(phi / TWO_PI)
        for b in self.model.holders.breaks:
            for m in (turns, turns + 1):
                cand = m * TWO_PI + b
                if phi + 1e-12 < cand < phi_end - 1e-12:
                    return cand
        return phi_end

    def _event_functions(self, mode: Mode, stop: float):
        model = self.model
        funcs, kinds = [], []

        def stop_event(_t, y):
            return y[0] - stop
        stop_event.terminal, stop_event.direction = True, 1.0
        funcs.append(stop_event)
        kinds.append(("stop", -1))
        if mode.stuck:                                  # output at rest: starts when driven
            funcs.append(_event(lambda y: model.drive_margin(y, mode), True, 1.0))
            kinds.append(("output_starts", -1))
        elif model.load.mean > 0:                       # moving: stops when ψ̇ reaches 0
            funcs.append(_event(lambda y: y[3] + self.eta * model.input_speed, True, -1.0))
            kinds.append(("output_stops", -1))
        for k in range(model.size):
            if mode.engaged[k]:
                funcs.append(_event(lambda y, k=k: model.release_function(y, mode)[k]
                                    + self.eta, True, -1.0))
                kinds.append(("release", k))
                funcs.append(_event(lambda y, k=k: model.forces(y, mode)[4][k], False, -1.0))
                kinds.append(("eps_max", k))
            else:
                if model.composite:             # Φ caught up with ψ, and the contact pushes
                    func = lambda y, k=k: min(                                     # noqa: E731
                        model.forces(y, mode)[3][k],
                        model.release_function(y, mode)[k]) - self.eta
                else:                                       # holder as fast as the output
                    func = lambda y, k=k: model.forces(y, mode)[4][k]              # noqa: E731
                funcs.append(_event(func, True, 1.0))
                kinds.append(("engage", k))
        return funcs, kinds

    def _switch(self, kind, k, y, mode: Mode, t, events) -> Mode:
        model = self.model
        if kind in ("output_stops", "output_starts"):
            stuck = kind == "output_stops" and model.drive_margin(y, mode) <= 0.0
            if kind == "output_stops":
                y[3] = 0.0          # held: exactly at rest (the event was ψ̇ = -η·ω1)
            self.counters.events += 1
            events.append(Event(t, y[0], kind, -1))
            return Mode(mode.engaged, mode.offset, stuck)
        engaged, offset = mode.engaged.copy(), mode.offset.copy()
        u, _, _, _, rel_speed, _ = model.forces(y, mode)
        if kind == "release":
            grazing = False
            if not model.composite and rel_speed[k] <= 0.0:
                accel = model.free_acceleration(y, mode, k)
                grazing = accel > 0 and -rel_speed[k] < GRAZE * self.turn_time * accel
            if grazing:
                kind = "graze"
                offset[k] = u[k] - y[2]
            else:
                engaged[k] = False
        else:
            engaged[k] = True
            if not model.composite:
                offset[k] = u[k] - y[2]
        self.counters.events += 1
        new = Mode(engaged, offset, mode.stuck)
        events.append(Event(t, y[0], kind, k, float(model.forces(y, new)[3][k]),
                            float(rel_speed[k])))
        return new

    def _count(self, sol) -> None:
        c = self.counters
        c.steps += max(sol.t.size - 1, 0)
        c.nfev += sol.nfev
        c.njev += sol.njev
        c.nlu += sol.nlu
        c.segments += 1

    def _record(self, trace: Trace, sol, mode: Mode, n: float) -> None:
        t0, t1 = sol.t[0], sol.t[-1]
        ts = np.linspace(t0, t1, max(int(np.ceil(n)), 2))
        ts = np.union1d(ts, sol.t)
        ys = sol.sol(ts) if sol.sol is not None else sol.y
        for j, tj in enumerate(ts):
            yj = ys[:, j]
            trace.t.append(tj)
            trace.y.append(yj)
            trace.eps.append(self.model.forces(yj, mode)[3])
            trace.engaged.append(mode.engaged.copy())


def _fired(sol, seg_events, kinds, y_start: np.ndarray, y_end: np.ndarray) -> list:
    """The terminal switches that happened in a segment, in the order of ``kinds``.

    ``solve_ivp`` stops at the first terminal root and drops every later one, even one at
    the same instant. Simultaneous switches are real here (a dead centre is where one
    freewheel lets go, the next closes and the turn ends), and a dropped one would be lost:
    its function starts the next segment on the far side of its root and never crosses it
    again. So a switch counts when ``solve_ivp`` reports it at the end, or when its function
    changed sign over the segment in its direction.
    """
    t_end = sol.t[-1]
    fired = []
    for j, (kind, wheel) in enumerate(kinds):
        if kind == "eps_max":
            continue
        reported = sol.t_events[j].size and sol.t_events[j][-1] >= t_end - 1e-15 * (
            1.0 + abs(t_end))
        func = seg_events[j]
        g0, g1 = func(0.0, y_start), func(t_end, y_end)
        crossed = g0 < 0 <= g1 if func.direction > 0 else g0 > 0 >= g1
        if reported or crossed:
            fired.append((kind, wheel))
    return fired


def _repeats(events: list[Event], t: float, wheel: int) -> bool:
    """Whether an ε maximum of ``wheel`` at ``t`` is recorded already: a peak that falls on a
    restart point (a dead centre) ends one segment and starts the next."""
    return any(e.kind == "eps_max" and e.wheel == wheel and e.t == t for e in events[-8:])


def _event(func, terminal: bool, direction: float):
    def event(_t, y):
        return func(y)
    event.terminal = terminal
    event.direction = direction
    return event

"""What a simulation ended in, and why, in one line.

``steady``
    the state at the start of a crank turn repeated after 1 to ``LONGEST_PERIOD`` turns
    (criterion in :mod:`optdesign.dynamics.steady`), and the output turns.
``stalled``
    the output stands still for a whole turn: with the ``ratchet`` model every freewheel
    winds its spring from ε = 0 at each stroke, so a turn in which the springs never
    overcome the load repeats for ever. (The ``composite`` spring keeps winding, so it always
    starts in the end.) A crank that cannot get round is a stall too
    (:class:`optdesign.dynamics.integrator.StallError`).
``not_steady``
    ``cycles`` ran out. The reason names the likeliest cause: a residual still falling
    (more turns needed), a composite freewheel whose output bounces on the driving
    profile (impacts every closing, never damped into a cycle), a load table that turns
    with the output, or a residual that does not fall.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: a repeating motion of up to this many crank turns is a steady cycle
LONGEST_PERIOD = 8
#: turns of residual history read to tell "still converging" from "not converging"
TREND_TURNS = 16


@dataclass(frozen=True)
class Verdict:
    status: str                   # steady | not_steady | stalled
    reason: str | None            # one line, None when steady


def held_whole_turn(model, events, stuck_at_start: bool, stuck_at_end: bool) -> bool:
    """The output stood still through a turn of the ratchet model: a stall."""
    return (not model.composite and stuck_at_start and stuck_at_end
            and not any(e.kind == "output_starts" for e in events))


def judge(model, section, turns: int, steady: bool, stalled: bool, residuals: list,
          events: list, impact: float) -> Verdict:
    """The verdict of a run: ``residuals`` the turn-to-turn residuals in order, ``events``
    those of the recorded cycle, ``impact`` the largest relative speed ε̇ at any closing of
    the run (0 for the ratchet, which closes at ε̇ = 0)."""
    if stalled:
        return Verdict("stalled", stall_reason(model, events))
    if steady:
        return Verdict("steady", None)
    return Verdict("not_steady", f"NOT steady after {turns} turn{'s' * (turns != 1)}: "
                                 f"{_cause(model, section, residuals, impact)}")


def stall_reason(model, peaks: list) -> str:
    """One line for an output that never moves; ``peaks`` the recorded turn's events."""
    top = max([model.stiffness[e.wheel] * e.eps for e in peaks if e.kind == "eps_max"],
              default=0.0)
    return (f"the output stalls: over a whole turn the freewheels' torque peaks at "
            f"{top:.3g} N·m and never exceeds the load's {model.load.mean:.3g} N·m "
            f"(stiffer freewheels, a larger holder swing or a lighter load would move it)")


def _cause(model, section, residuals: list, impact: float) -> str:
    tol = section.steady_tol
    if not residuals:
        return "one turn leaves nothing to compare (raise cycles)"
    periods = f"no motion of 1 to {min(LONGEST_PERIOD, len(residuals))} turns repeats"
    if model.composite and impact > 1e-6 * model.input_speed:
        return _bouncing(model, impact, periods)
    if model.load.table:
        return ("the load table turns with the output, whose turn is not a whole number of "
                "crank turns, so the state need not repeat (a constant load would)")
    recent = np.asarray(residuals[-TREND_TURNS:], dtype=float)
    last = recent[-1]
    rate = _convergence_rate(recent)
    if rate is not None:
        more = int(np.ceil(np.log(tol / last) / np.log(rate)))
        return (f"still converging: the residual fell from {recent[0]:.2g} to {last:.2g} over "
                f"the last {recent.size} turns, by {rate:.3g} a turn (steady_tol {tol:g}; "
                f"about {more} more turns at this rate: raise cycles)")
    change = f"the turn-start state still changes by {last:.2g} (steady_tol {tol:g})"
    if len(residuals) < 2 * LONGEST_PERIOD:
        return f"{change} and {periods}; too few turns to tell more (raise cycles)"
    ringing = ""
    if model.section.damping_ratio == 0:
        omega = float(np.sqrt(np.max(model.stiffness) / model.I2))
        ringing = (f"; the undamped freewheel springs ring at √(λ/I2) = {omega:.3g} rad/s "
                   f"({omega / model.input_speed:.3g} times the crank speed) and little damps "
                   f"them (damping_ratio > 0 would)")
    return f"{change} and {periods}{ringing}"


def _convergence_rate(recent: np.ndarray) -> float | None:
    """The residual's factor per turn when it falls steadily (log-linear fit over at least
    6 turns, slope below log 0.98, R² ≥ 0.8), else None: a chaotic residual that happens to
    be lower at the end of the window is not convergence."""
    if recent.size < 6 or not np.all(np.isfinite(recent)) or np.any(recent <= 0):
        return None
    turns = np.arange(recent.size, dtype=float)
    logs = np.log(recent)
    slope, intercept = np.polyfit(turns, logs, 1)
    spread = np.sum((logs - logs.mean()) ** 2)
    fit = 1.0 - np.sum((logs - slope * turns - intercept) ** 2) / spread if spread > 0 else 0.0
    return float(np.exp(slope)) if slope < np.log(0.98) and fit >= 0.8 else None


def _bouncing(model, impact: float, periods: str) -> str:
    """The composite freewheel's output bounces on Φ; when Φ shakes harder than the load
    brakes (Γ > 1), like a ball on a vibrating table, it cannot even stay on it."""
    zeta = model.section.damping_ratio
    returns = "in full" if zeta == 0 else f"in part (damping ratio {zeta:g})"
    text = (f"the composite freewheel closes with impacts (up to {impact:.3g} rad/s at ε = 0) "
            f"that its spring returns {returns}, so the output bounces on the driving profile "
            f"Φ and {periods}")
    phis = np.linspace(0.0, 2.0 * np.pi, 721)
    shake = max(abs(float(model.holders(p)[2][0])) for p in phis) * model.input_speed ** 2
    brake = model.load.mean / model.I2
    if shake > brake:
        ratio = f", {shake / brake:.3g} times the load's braking T_c/I2" if brake > 0 else ""
        text += (f"; Φ accelerates at up to {shake:.3g} rad/s²{ratio}, so the output cannot "
                 f"follow it and takes off after every landing, like a ball on a vibrating "
                 f"table")
    return text + " (the ratchet model closes without impact)"

"""The two-mass drive with compliant freewheels (Ambartsumyants & Subbotina 2015, eqs. 3-4).

Coordinates: crank angle φ (input side, inertia I1, motor torque T_d = a - b·φ̇) and output angle
ψ (output side, inertia I2, resisting load T_c). Freewheel k has a driving holder whose angle is a
function of the crank, u_k(φ), and a relative angle (the paper's ε)

    ε_k = u_k(φ) - ψ - c_k,

which it turns into the torque λ_k·ε_k only while engaged (the paper's asymmetric unit function
λ(ε) = λ·[ε > 0]). An optional viscous term c_k·ε̇_k (``damping_ratio``; the paper has none)
lets the ringing of stiff freewheels decay. Lagrange's equations with kinetic energy
½I1·φ̇² + ½I2·ψ̇² and spring energy ½λ_k·ε_k² give eq. (3) of the paper written in (φ, ψ)
instead of (φ, ε):

    I1·φ̈ = a - b·φ̇ - Σ_k λ_k·ε_k·u_k'(φ)      (the reaction reaches the crank through u_k')
    I2·ψ̈ = Σ_k λ_k·ε_k - T_c(ψ)

and, with every freewheel released, eq. (4): I1·φ̈ = a - b·φ̇, I2·ψ̈ = -T_c. The load
resists: it brakes the output but never turns it backwards, so an output that comes to rest
stays there (ψ̇ = 0) until the freewheel torque exceeds T_c again. Jamming (ε rising),
joint motion and overrun (ε back to 0, the output faster than the holder) are not imposed: they
follow from these equations and from the switching rule of the freewheel model:

``ratchet`` (default, any number of freewheels)
    one holder per output member and stroke sign, u_k = g·s·θ_k(φ) (g the ``reduction``); a
    released freewheel slips, so it re-engages when the holder's speed reaches the output's
    (u_k'·φ̇ = ψ̇) and its reference c_k is reset there (ε_k = 0).
``composite`` (the paper's reading)
    one compliant freewheel on the composed position function Φ(φ) of the whole converter (the
    rigid-freewheel output angle, eq. 1-2 for the pulse reducer), c = 0 for ever: after an
    overrun it re-engages only when Φ has caught up with ψ (the paper's t3: Φ(t) = ψ(t)).
    It closes with an impact (ε̇ > 0 at ε = 0), which an undamped spring returns in full, so
    the output may bounce for ever; with damping it is a unilateral Kelvin-Voigt contact that
    pushes only (torque λ·ε + c·ε̇ > 0) and loses energy at every impact.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from optdesign.dynamics.section import DynamicsSection, LoadTable
from optdesign.envelope.exact import exact_figures
from optdesign.envelope.sampled import STROKE_SIGNS
from optdesign.errors import ProblemError
from optdesign.numerics.buffered import BufferedCall

TWO_PI = 2.0 * np.pi
#: state vector: crank angle, crank speed, output angle, output speed, motor work, load work.
STATE = ("phi", "omega_in", "psi", "omega_out", "work_in", "work_out")


class Load:
    """Resisting torque T_c(ψ) and its slope; a table is periodic over one output turn."""

    def __init__(self, load: float | LoadTable):
        self.table = isinstance(load, LoadTable)
        if self.table:
            ang = np.radians(load.angle_deg)
            tq = np.asarray(load.torque, dtype=float)
            if ang[0] > 0 or ang[-1] < TWO_PI:       # close the period through 0 = 360°
                ang = np.concatenate([[ang[-1] - TWO_PI], ang, [ang[0] + TWO_PI]])
                tq = np.concatenate([[tq[-1]], tq, [tq[0]]])
            self.angle, self.torque = ang, tq
            area = np.sum(0.5 * (tq[1:] + tq[:-1]) * np.diff(ang))
            self.mean = float(area / (ang[-1] - ang[0]))
        else:
            self.value = float(load)
            self.mean = self.value

    def __call__(self, psi: float) -> tuple[float, float]:
        if not self.table:
            return self.value, 0.0
        x = psi % TWO_PI
        j = int(np.clip(np.searchsorted(self.angle, x, side="right") - 1, 0,
                        self.angle.size - 2))
        slope = (self.torque[j + 1] - self.torque[j]) / (self.angle[j + 1] - self.angle[j])
        return float(self.torque[j] + slope * (x - self.angle[j])), float(slope)


class Holders:
    """Holder angles u_k(φ), u_k', u_k'' of the ``ratchet`` model: g·s·θ_k from CasADi."""

    def __init__(self, design, stroke: str, reduction: float):
        import casadi as ca

        self.count = design.count
        # The design's kinematics with its lengths fixed, evaluated through a CasADi buffer:
        # the integrator calls it ~10^5 times, and the plain call costs ~40 µs of conversions.
        phi = ca.MX.sym("phi")
        theta, dtheta, ddtheta, _ = design.function()(phi, ca.DM(design.p(1.0)))
        self.function = ca.Function("holders", [phi], [ca.vertcat(theta, dtheta, ddtheta)])
        self._evaluate = BufferedCall(self.function)     # this object's own buffer
        self.signs = np.repeat(np.asarray(STROKE_SIGNS[stroke], dtype=float), self.count)
        self.gain = reduction * self.signs
        self.chain = np.tile(np.arange(self.count), len(STROKE_SIGNS[stroke]))
        self.size = self.chain.size
        self.breaks = tuple(sorted({float(b) % TWO_PI for b in design.breakpoints(1.0)}))
        self._last_phi = None
        self._last = None

    def labels(self) -> list[str]:
        sign = {1.0: "+", -1.0: "-"}
        many = len(set(self.signs)) > 1
        return [f"{k + 1}{sign[s] if many else ''}" for k, s in zip(self.chain, self.signs)]

    def __call__(self, phi: float):
        phi = float(phi)
        if phi != self._last_phi:       # the event functions ask again at the same angle
            res = self._evaluate(phi)
            n = self.count
            self._last = tuple(self.gain * res[i * n:(i + 1) * n][self.chain]
                               for i in range(3))
            self._last_phi = phi
        return self._last


class ComposedPosition:
    """Φ(φ) of the ``composite`` model: the rigid output angle ∫ max(0, max_k u_k') dφ.

    Built from the exact envelope's runs (:func:`optdesign.envelope.exact.exact_figures`): on a run where
    holder k drives, Φ = Φ(start) + u_k(φ) - u_k(start), so Φ is exact, continuous, and grows by
    Φ_turn per crank turn; Φ'' jumps at the hand-overs, which are therefore restart points.
    """

    size = 1

    def __init__(self, design, stroke: str, reduction: float):
        self.holders = Holders(design, stroke, reduction)
        _, runs = exact_figures(design, stroke, 1.0)
        self.runs = []
        base = 0.0
        for run in runs:
            rest = run.curve >= self.holders.size
            # exact.py stacks curves sign-major like Holders, so the indices agree
            start_u = 0.0 if rest else float(self.holders(run.start % TWO_PI)[0][run.curve])
            self.runs.append((run.start, run.end, run.curve, base, start_u, rest))
            if not rest:
                end_u = float(self.holders(run.end % TWO_PI)[0][run.curve])
                base += _wrapped(end_u - start_u)
        self.turn = base
        starts = [r[0] % TWO_PI for r in self.runs]
        self.breaks = tuple(sorted(set(starts) | set(self.holders.breaks)))
        self.origin = self.runs[0][0]

    def labels(self) -> list[str]:
        return ["Φ"]

    def __call__(self, phi: float):
        shifted = phi - self.origin
        turns = np.floor(shifted / TWO_PI)
        local = self.origin + shifted - turns * TWO_PI         # in [origin, origin + 2π)
        for start, end, curve, base, start_u, rest in self.runs:
            if local < end or end >= self.origin + TWO_PI - 1e-15:
                break
        value = turns * self.turn + base
        if rest:
            return np.array([value]), np.zeros(1), np.zeros(1)
        u, du, ddu = self.holders(local % TWO_PI)
        value += _wrapped(u[curve] - start_u)
        return np.array([value]), du[curve:curve + 1], ddu[curve:curve + 1]


def _wrapped(angle):
    return (angle + np.pi) % TWO_PI - np.pi


@dataclass
class Mode:
    """The discrete state: which freewheels are engaged, their references c_k, and whether
    the output is held at rest by its load (a resisting load does not turn it backwards)."""

    engaged: np.ndarray        # bool per freewheel
    offset: np.ndarray         # c_k, rad
    stuck: bool = False        # ψ̇ = 0 while the freewheel torque does not exceed T_c


class DriveModel:
    """Right-hand side, Jacobian and switching functions of the drive (eqs. 3-4)."""

    def __init__(self, design, stroke: str, input_speed: float, section: DynamicsSection,
                 where: str = "<problem>"):
        count = design.count
        if len(section.stiffness) not in (1, count):
            raise ProblemError(f"{where}: dynamics.stiffness must have one value or one per "
                               f"phase (got {len(section.stiffness)} for {count} phases)")
        self.section = section
        self.input_speed = float(input_speed)
        self.composite = section.freewheel == "composite"
        self.constant_crank = section.crank == "constant"
        cls = ComposedPosition if self.composite else Holders
        self.holders = cls(design, stroke, section.reduction)
        lam = np.asarray(section.stiffness_per_phase(count), dtype=float)
        n_signs = len(STROKE_SIGNS[stroke])
        self.stiffness = (np.array([lam.mean()]) if self.composite else np.tile(lam, n_signs))
        # c_k = 2ζ·√(λ_k·I2): ζ the damping ratio of the output on one freewheel (0: paper)
        self.damping = 2.0 * section.damping_ratio * np.sqrt(self.stiffness * section.I2)
        self.load = Load(section.load)
        self.a, self.b = section.motor_a, section.motor_b
        self.I1, self.I2 = section.I1, section.I2
        self.psi_origin = 0.0          # absolute output angle of ψ = 0 (for a load table)

    @property
    def size(self) -> int:
        return self.holders.size

    def labels(self) -> list[str]:
        return self.holders.labels()

    # ------------------------------------------------------------------ dynamics
    def motor_torque(self, omega: float) -> float:
        return self.a - self.b * omega

    def forces(self, y, mode: Mode):
        """Holder kinematics, relative angles ε_k, relative speeds ε̇_k and torques
        λ_k·ε_k + c_k·ε̇_k of the engaged freewheels."""
        u, du, ddu = self.holders(y[0])
        eps = u - y[2] - mode.offset
        rel_speed = du * y[1] - y[3]
        torque = np.where(mode.engaged, self.stiffness * eps + self.damping * rel_speed, 0.0)
        return u, du, ddu, eps, rel_speed, torque

    def release_function(self, y, mode: Mode) -> np.ndarray:
        """Torque over stiffness, ε_k + (c_k/λ_k)·ε̇_k: an engaged freewheel lets go at 0."""
        _, _, _, eps, rel_speed, _ = self.forces(y, mode)
        return eps + self.damping / self.stiffness * rel_speed

    def rhs(self, y, mode: Mode) -> np.ndarray:
        """dy/dt of (φ, φ̇, ψ, ψ̇, W_in, W_out): eq. (3) engaged, eq. (4) released."""
        _, du, _, _, _, torque = self.forces(y, mode)
        load, _ = self.load(y[2] + self.psi_origin)
        reaction = float(torque @ du)
        if self.constant_crank:
            accel_in, power_in = 0.0, reaction * y[1]
        else:
            motor = self.motor_torque(y[1])
            accel_in, power_in = (motor - reaction) / self.I1, motor * y[1]
        if mode.stuck:
            return np.array([y[1], accel_in, 0.0, 0.0, power_in, 0.0])
        accel_out = (torque.sum() - load) / self.I2
        return np.array([y[1], accel_in, y[3], accel_out, power_in, load * y[3]])

    def drive_margin(self, y, mode: Mode) -> float:
        """Σ_k λ_k·ε_k minus the load: the output at rest starts when it turns positive."""
        load, _ = self.load(y[2] + self.psi_origin)
        return float(self.forces(y, mode)[5].sum() - load)

    def jacobian(self, y, mode: Mode) -> np.ndarray:
        """∂(dy/dt)/∂y, analytic (the implicit integrators' Newton matrix)."""
        _, du, ddu, _, _, torque = self.forces(y, mode)
        lam = np.where(mode.engaged, self.stiffness, 0.0)
        damp = np.where(mode.engaged, self.damping, 0.0)
        load, slope = self.load(y[2] + self.psi_origin)
        w = y[1]
        # partial derivatives of the freewheel torques F_k = λ_k·ε_k + c_k·ε̇_k
        f_phi = lam * du + damp * ddu * w
        f_w, f_psi, f_W = damp * du, -lam, -damp
        # and of the reaction on the crank R = Σ F_k·u_k'
        r_phi = float(f_phi @ du + torque @ ddu)
        r_w, r_psi, r_W = float(f_w @ du), float(f_psi @ du), float(f_W @ du)
        jac = np.zeros((6, 6))
        jac[0, 1] = 1.0
        jac[2, 3] = 1.0
        if self.constant_crank:
            reaction = float(torque @ du)
            jac[4] = [r_phi * w, reaction + r_w * w, r_psi * w, r_W * w, 0.0, 0.0]
        else:
            jac[1] = [-r_phi / self.I1, (-self.b - r_w) / self.I1, -r_psi / self.I1,
                      -r_W / self.I1, 0.0, 0.0]
            jac[4, 1] = self.a - 2.0 * self.b * w
        if mode.stuck:
            jac[2, 3] = 0.0
            return jac
        jac[3] = [f_phi.sum() / self.I2, f_w.sum() / self.I2, (f_psi.sum() - slope) / self.I2,
                  f_W.sum() / self.I2, 0.0, 0.0]
        jac[5, 2] = slope * y[3]
        jac[5, 3] = load
        return jac

    def free_acceleration(self, y, mode: Mode, k: int) -> float:
        """ε̈_k with freewheel k released: > 0 means it would re-engage at once (a graze)."""
        trial = Mode(mode.engaged.copy(), mode.offset, mode.stuck)
        trial.engaged[k] = False
        dy = self.rhs(y, trial)
        _, du, ddu = self.holders(y[0])
        return float(ddu[k] * y[1] ** 2 + du[k] * dy[1] - dy[3])

    def kinetic_energy(self, y) -> float:
        return 0.5 * self.I1 * y[1] ** 2 + 0.5 * self.I2 * y[3] ** 2

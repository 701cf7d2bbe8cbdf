"""The NLP of one phase count: free lengths (scaled to O(1)) -> least ripple, solved by IPOPT.

Sign convention, stated once: every inequality is g(x) >= 0.

Speeds are per unit crank speed, f_c(φ) = s·dθ_k/dφ for each curve c = (stroke sign s,
rocker k) (shared/DESIGN.md 1.1). For each eccentricity e the NLP carries

* ``w_hi`` (ω_max/ω1): one stationary point φ_m,c per curve with ``f_c'(φ_m,c) = 0`` and
  ``w_hi - f_c(φ_m,c) >= 0``, so the peak is exact, not O(h²) (``solver: {peak_samples:
  true}`` adds the epigraph ``w_hi - f_c(φ_j) >= 0`` at every sample as a safety net; it
  costs n·N constraints and gains nothing on our benchmarks);
* ``w_lo`` (ω_min/ω1): for every hand-over of the envelope from curve a to curve b, a free
  angle φ_x with ``f_a(φ_x) - w_lo >= 0`` and ``f_b(φ_x) - w_lo >= 0``. Maximising w_lo puts
  φ_x where min(f_a, f_b) peaks, i.e. at the crossing, whose value is the envelope's local
  minimum: exact and conservative, with no equality that can become infeasible. Minima inside
  a run are held by ``logsumexp_ρ(f(φ_j)) - w_lo >= 0`` at the samples (the conservative
  smooth maximum of DESIGN.md section 2 where no crossing is involved);
* the time mean: on the run of curve c between hand-overs u and v, ∫ f_c dφ = θ_c(v) - θ_c(u),
  so mean = Σ runs (θ_c(v) - θ_c(u))/2π. Any wrong boundary selects a lower curve, so the
  sum never exceeds the true mean (conservative for the ratio); it is exact at the crossings.

The hand-over sequence (which curve follows which) comes from the exact evaluator at the start
design; the driver re-checks it at the optimum and re-solves if it changed.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from ..mechanisms import STROKE_SIGNS

#: weight of the worst ripple in the ``minimize: -ratio`` objective (a tie-break, see _build)
RIPPLE_TIE_BREAK = 1e-6

IPOPT_OPTIONS = {
    "ipopt.print_level": 0,
    "ipopt.tol": 1e-9,
    "ipopt.acceptable_tol": 1e-6,
    "ipopt.mu_strategy": "adaptive",
    "ipopt.nlp_scaling_method": "gradient-based",
    "ipopt.sb": "yes",
    "ipopt.bound_relax_factor": 0.0,          # bounds are the designer's: keep them exactly
    "ipopt.constr_viol_tol": 1e-8,
    "print_time": False,
}


@dataclass
class Block:
    """A named slice of the decision or constraint vector."""

    name: str
    start: int
    size: int


@dataclass
class Layout:
    """Where each quantity sits in x and g, so results and bindings can be read by name."""

    x: list[Block] = field(default_factory=list)
    g: list[Block] = field(default_factory=list)

    def add(self, blocks: list[Block], name: str, size: int) -> slice:
        start = blocks[-1].start + blocks[-1].size if blocks else 0
        blocks.append(Block(name, start, size))
        return slice(start, start + size)

    def find(self, blocks: list[Block], name: str) -> slice:
        b = next(b for b in blocks if b.name == name)
        return slice(b.start, b.start + b.size)

    def name_of(self, blocks: list[Block], index: int) -> str:
        return next(b.name for b in blocks if b.start <= index < b.start + b.size)


def smooth_max(values, rho):
    """log-sum-exp maximum, (1/ρ)·log Σ exp(ρ·v) >= max v, shifted by max v for stability.

    The shift cancels in value and in every derivative (the softmax weights sum to one), so
    the non-smooth ``mmax`` only guards the exponent's range.
    """
    top = ca.mmax(values)
    return top + ca.log(ca.sum1(ca.exp(rho * (values - top)))) / rho


def _wrap(angle):
    """Angle difference wrapped to (-π, π]: rockers swing less than half a turn per run."""
    return ca.atan2(ca.sin(angle), ca.cos(angle))


class PhaseNLP:
    """The NLP for one phase count and one hand-over sequence per eccentricity.

    Parameters (``p`` of the solver): the fixed lengths, then ``min_ratio`` and ``max_ripple``,
    so a Pareto sweep re-solves the same NLP with another ε.
    """

    def __init__(self, problem, count: int, sequences: tuple[tuple[int, ...], ...]):
        self.problem = problem
        self.count = count
        self.sequences = sequences
        model = problem.model
        self.model = model
        self.free = problem.free_lengths()
        self.fixed = [k for k in model.lengths if k not in self.free]
        # geometric mean of the bounds: O(1) scaled variables even when a range spans decades
        self.scale = np.array([math.sqrt(problem.design[k].lower * problem.design[k].upper)
                               for k in self.free])
        self.signs = STROKE_SIGNS[problem.stroke]
        self.n_curves = count * len(self.signs)
        self.eccs = self._eccentricities()
        s = problem.solver
        self.phi = np.linspace(0.0, 2 * math.pi, s.samples, endpoint=False)
        self.layout = Layout()
        self._build()

    def _eccentricities(self) -> tuple[float, ...]:
        """Listed fractions, plus e = 1 where the ratio is defined (first)."""
        return (1.0,) + tuple(e for e in self.problem.eccentricities if e != 1.0)

    # ------------------------------------------------------------------ building
    def _build(self):
        P, L = self.problem, self.layout
        fn = self.model.kinematics(self.count, tuple(sorted(P.options.items())))
        xs = ca.MX.sym("x", len(self.free))
        ps = ca.MX.sym("p", len(self.fixed) + 2)
        L.add(L.x, "lengths", len(self.free))
        lengths = {k: xs[i] * self.scale[i] for i, k in enumerate(self.free)}
        lengths |= {k: ps[i] for i, k in enumerate(self.fixed)}
        min_ratio, max_ripple = ps[len(self.fixed)], ps[len(self.fixed) + 1]

        x_parts, g_parts, lbg, ubg = [xs], [], [], []

        def constrain(name, expr, lower=0.0, upper=math.inf):
            L.add(L.g, name, expr.numel())
            g_parts.append(expr)
            lbg.extend([lower] * expr.numel())
            ubg.extend([upper] * expr.numel())

        def variable(name, size):
            v = ca.MX.sym(name, size)
            L.add(L.x, name, size)
            x_parts.append(v)
            return v

        mu_min = P.constraints.min_transmission_angle_deg
        cos_limit = min(math.cos(math.radians(mu_min)),
                        math.sqrt(1.0 - P.constraints.assembly_margin))
        rho = P.solver.smoothing
        N = self.phi.size
        fmap = fn.map(N)
        ripples, means, peaks = [], [], []
        for e_index, e in enumerate(self.eccs):
            tag = f"e{e:g}"
            pvec = ca.vertcat(*[lengths[k] * (e if k == self.model.regulating_variable else 1)
                                for k in self.model.lengths])
            theta, dtheta, _, cos_mu = fmap(self.phi[None, :], pvec)
            # Speeds of eccentricity e in units of e·ω1: they shrink like e, and at e = 1e-6
            # they would sit below IPOPT's tolerances and bound push (DESIGN.md 1.1: ripple
            # and ratio are ratios, so the unit cancels).
            dtheta = dtheta / e
            f = ca.vertcat(*[s * dtheta for s in self.signs])            # curves × N
            w = variable(f"w_{tag}", 2)
            w_hi, w_lo = w[0], w[1]
            constrain(f"transmission_angle[{tag}]",
                      cos_limit**2 - ca.vec(cos_mu) ** 2)
            if P.solver.peak_samples:
                constrain(f"peak_samples[{tag}]", ca.vec(w_hi - f))
            lse = ca.vertcat(*[smooth_max(f[:, j], rho) for j in range(N)])
            constrain(f"trough_samples[{tag}]", lse - w_lo)
            # Exact peaks: one stationary point per curve.
            phi_m = variable(f"phi_peak_{tag}", self.n_curves)
            _, dth_m, ddth_m, _ = fn.map(self.n_curves)(phi_m.T, pvec)
            dth_m, ddth_m = dth_m / e, ddth_m / e
            f_m = ca.vertcat(*[self._curve(dth_m, c, c) for c in range(self.n_curves)])
            df_m = ca.vertcat(*[self._curve(ddth_m, c, c) for c in range(self.n_curves)])
            constrain(f"peak_stationary[{tag}]", df_m, 0.0, 0.0)
            constrain(f"peak_points[{tag}]", w_hi - f_m)
            # Exact troughs at the hand-overs, and the exact mean over the runs.
            seq = self.sequences[e_index]
            m = len(seq)
            phi_x = variable(f"phi_handover_{tag}", m)
            th_x, dth_x, _, _ = fn.map(m)(phi_x.T, pvec)
            dth_x = dth_x / e
            lows, mean = [], 0
            for i in range(m):
                before, after = seq[i - 1], seq[i]
                lows += [self._curve(dth_x, before, i) - w_lo, self._curve(dth_x, after, i) - w_lo]
                if after < self.n_curves:                     # not the output-at-rest curve
                    nxt = (i + 1) % m
                    mean += _wrap(self._curve(th_x, after, nxt) - self._curve(th_x, after, i))
            constrain(f"trough_handovers[{tag}]", ca.vertcat(*lows))
            mean = mean / (2 * math.pi * e)
            definition = P.objective.ripple
            avg = 0.5 * (w_hi + w_lo) if definition == "midrange" else mean
            ripples.append((w_hi - w_lo) / avg)
            means.append(mean)
            peaks.append(w_hi)
        self.ratio_expr = means[0]
        constrain("min_ratio", means[0] - min_ratio)
        for name, g in self.model.design_constraints(lengths, self.count, P.constraints):
            constrain(name, ca.vertcat(g))
        if P.constraints.grashof and hasattr(self.model, "grashof_constraints"):
            for name, g in self.model.grashof_constraints(lengths):
                constrain(name, ca.vertcat(g))
        for key, section in P.sections.items():
            if hasattr(section, "solve_constraints"):
                for name, g in section.solve_constraints(P, peaks[0] * P.input_speed):
                    constrain(f"{key}.{name}", ca.vertcat(g))
        listed = [i for i, e in enumerate(self.eccs) if e in P.eccentricities]
        t = variable("worst_ripple", 1)
        constrain("ripple_epigraph", ca.vertcat(*[t - ripples[i] for i in listed]))
        if P.objective.minimize == "ripple":
            objective = t
        else:
            constrain("max_ripple", max_ripple - t)
            # The ripple term breaks the tie lexicographically: it keeps w_hi and w_lo tight
            # when the cap is slack (so the surrogate δ stays exact) for at most ~1e-6 of ratio.
            objective = -means[0] + RIPPLE_TIE_BREAK * t
        x = ca.vertcat(*x_parts)
        g = ca.vertcat(*g_parts)
        self.lbg, self.ubg = np.array(lbg), np.array(ubg)
        self.surrogate = ca.Function("surrogate", [x, ps],
                                     [ca.vertcat(*ripples), ca.vertcat(*means),
                                      ca.vertcat(*peaks)])
        opts = dict(IPOPT_OPTIONS) | {"ipopt.max_iter": P.solver.max_iter, "expand": True,
                                      "ipopt.hessian_approximation": P.solver.hessian}
        self.solver = ca.nlpsol(f"nlp_n{self.count}", "ipopt",
                                {"x": x, "p": ps, "f": objective, "g": g}, opts)
        self.n_x = x.numel()

    def _curve(self, rows, c, col):
        """Curve c of the stacked (sign, rocker) curves from rows over rockers, at column col."""
        if c >= self.n_curves:                                   # output at rest
            return ca.MX(0)
        return self.signs[c // self.count] * rows[c % self.count, col]

    # ------------------------------------------------------------------ parameters
    def parameters(self, min_ratio: float | None = None, max_ripple: float | None = None):
        P = self.problem
        fixed = [P.design[k].value for k in self.fixed]
        return np.array(fixed + [P.objective.min_ratio if min_ratio is None else min_ratio,
                                 (P.objective.max_ripple or 1.0) if max_ripple is None
                                 else max_ripple], dtype=float)

    def bounds(self, guess: dict) -> tuple[np.ndarray, np.ndarray]:
        """Variable bounds: the design's bounds, and windows around the start's angles."""
        P, L = self.problem, self.layout
        lbx, ubx = np.full(self.n_x, -np.inf), np.full(self.n_x, np.inf)
        sl = L.find(L.x, "lengths")
        lbx[sl] = [P.design[k].lower / s for k, s in zip(self.free, self.scale)]
        ubx[sl] = [P.design[k].upper / s for k, s in zip(self.free, self.scale)]
        half_window = math.pi / self.n_curves
        for block in L.x:
            if block.name.startswith(("phi_peak", "phi_handover")):
                sl = slice(block.start, block.start + block.size)
                lbx[sl] = guess[block.name] - half_window
                ubx[sl] = guess[block.name] + half_window
            elif block.name.startswith("w_"):
                sl = slice(block.start, block.start + block.size)
                lbx[sl] = 0.0
        return lbx, ubx

    def at_window_bound(self, x, lbx, ubx, tol: float = 1e-6) -> bool:
        """True when a tracked angle (peak or hand-over) ended on the edge of its window:
        the point moved further than the window allows, so the driver re-centres and
        re-solves."""
        for block in self.layout.x:
            if block.name.startswith(("phi_peak", "phi_handover")):
                sl = slice(block.start, block.start + block.size)
                if np.any(x[sl] - lbx[sl] < tol) or np.any(ubx[sl] - x[sl] < tol):
                    return True
        return False

    def lengths_of(self, x: np.ndarray) -> dict[str, float]:
        """The free lengths in mm, clipped to their bounds (IPOPT may relax a bound by ~1e-8)."""
        sl = self.layout.find(self.layout.x, "lengths")
        P = self.problem
        return {k: float(np.clip(v * s, P.design[k].lower, P.design[k].upper))
                for k, v, s in zip(self.free, x[sl], self.scale)}

    def pack(self, guess: dict) -> np.ndarray:
        x0 = np.zeros(self.n_x)
        for block in self.layout.x:
            x0[block.start:block.start + block.size] = guess[block.name]
        return x0

    def unpack(self, x: np.ndarray) -> dict:
        return {b.name: np.array(x[b.start:b.start + b.size]) for b in self.layout.x}


"""Can any reading of Sharkov & Kalinin 2022 reproduce BOTH strokes of its table?

The paper (its results section; docs/papers.md, section 1) gives, for l0=225, l1=20, l2=225, l2'=100, l3=56 mm, n=6:
    forward  ω_max 39.8  ω_min 27.2  ω_cp 33.5  δ 0.376
    reverse  ω_max 44.1  ω_min 29.5  ω_cp 36.8  δ 0.397
(ω1 is not stated; optdesign uses 97 rad/s, which fits the forward stroke.)

This script tabulates forward and reverse (ω_max, ω_min, ω_avg = midrange, δ) for every
reading tried, with ``err`` = worst relative error of the four extremes against the paper at
ω1 = 97 and ``err*`` the same after the best ω1 (log least squares, shown as ``ω1*``):

  A. the paper's own arithmetic (is ω_cp the midrange, is δ = (max-min)/ω_cp?);
  B. optdesign's exact evaluator (collinear pins |AC_i| = l2-l2', and eq. (2) text |AC_i| = l2');
  C. geometric readings in numpy: pin radius, pin numbering mirrored, crank turned the other
     way, assembly branch of every chain (all 64 combinations, best shown), envelope over a
     subset of the chains (all 63 subsets, best shown), time mean instead of midrange;
  D. the paper's velocity formula (8) to the letter: arctan vs atan2 for γ_i and ψ_i, velocity
     plan axis at φ2 (eq. 7) or 180°+φ2 (text), v_CiA = v_B1A·l2'/l2 (text) or ·|AC_i|/l2,
     and the sign of (8) as printed or flipped;
  E. a continuous scan of the pin radius |AC_i| (what forward and reverse δ it gives).

Finding: nothing reproduces both strokes. The forward-exact reading gives reverse δ = 0.430;
every reading that keeps the forward figures within ~1 % leaves the reverse ones >= 4 % off.

Run: ``PYTHONPATH=. .venv/bin/python benchmarks/reverse_stroke_readings.py`` (a few seconds).
"""
from __future__ import annotations

import itertools
import warnings

import numpy as np

from optdesign.evaluation.design import Design
from optdesign.envelope.exact import exact_figures

L0, L1, L2, L2P, L3, N, W1 = 225.0, 20.0, 225.0, 100.0, 56.0, 6, 97.0
TAU = 2 * np.pi / N
PAPER = {"forward": (39.8, 27.2, 33.5, 0.376), "reverse": (44.1, 29.5, 36.8, 0.397)}
PAPER_EXTREMES = np.array([39.8, 27.2, 44.1, 29.5])
PHI = np.linspace(0.0, 2 * np.pi, 65536, endpoint=False)   # 0.0055° grid: extremes to ~0.005
H = 1e-6                                                    # central-difference step, rad


# ----------------------------------------------------------------------------- figures
def figures(omega: np.ndarray, mean: bool = False) -> tuple[float, float, float, float]:
    """(ω_max, ω_min, ω_avg, δ) of the envelope max(0, max_k ω_k); ω_avg midrange or time mean."""
    env = omega.max(axis=0).clip(min=0.0)
    hi, lo = env.max(), env.min()
    avg = env.mean() if mean else 0.5 * (hi + lo)
    return hi, lo, avg, (hi - lo) / avg


def both_strokes(omega: np.ndarray, mean: bool = False):
    """Forward (output = max ω_k) and reverse (output = max -ω_k) figures."""
    return figures(omega, mean), figures(-omega, mean)


def errors(fwd, rev) -> tuple[float, float, float]:
    """Worst relative error of the four extremes at ω1 = 97, and after the best ω1 scale."""
    v = np.array([fwd[0], fwd[1], rev[0], rev[1]])
    if not (v > 0).all():                       # a stroke with dead zones: no fit
        return np.inf, np.inf, np.nan
    scale = np.exp(np.mean(np.log(PAPER_EXTREMES / v)))
    return (np.abs(v / PAPER_EXTREMES - 1).max(), np.abs(v * scale / PAPER_EXTREMES - 1).max(),
            W1 * scale)


def row(name: str, fwd, rev) -> str:
    e, es, w1 = errors(fwd, rev)
    f = " ".join(f"{x:6.2f}" for x in fwd[:3]) + f" {fwd[3]:6.3f}"
    r = " ".join(f"{x:6.2f}" for x in rev[:3]) + f" {rev[3]:6.3f}"
    return f"{name:<52s} | {f} | {r} | {e:5.1%} {es:5.1%} {w1:6.1f}"


HEADER = (f"{'reading':<52s} | {'fwd max':>6s} {'min':>6s} {'avg':>6s} {'δ':>6s} | "
          f"{'rev max':>6s} {'min':>6s} {'avg':>6s} {'δ':>6s} |   err  err*   ω1*")


def section(title: str) -> None:
    print(f"\n{title}\n{HEADER}\n{'-' * len(HEADER)}")


# ----------------------------------------------------------------------------- geometry
def circle_point(p, r_p, q, r_q, branch):
    """Point at r_p from p and r_q from q, left (+1) or right (-1) of p -> q (complex)."""
    d = q - p
    dist = np.abs(d)
    along = (r_p**2 - r_q**2 + dist**2) / (2 * dist)
    with np.errstate(invalid="ignore"):
        half = np.sqrt(r_p**2 - along**2)
    ex = d / dist
    return p + along * ex + branch * half * 1j * ex


def rocker_angles(phi, radius, branches, pin_dir=1):
    """θ_k (direction O_kB_k) of the six rockers; branches[k] = +1 'left' as in optdesign."""
    a = L1 * np.exp(1j * phi)
    b1 = circle_point(a, L2, L0 + 0j, L3, branches[0])
    phi2 = np.angle(b1 - a)
    theta = [np.angle(b1 - L0)]
    for i in range(2, N + 1):
        o = L0 * np.exp(1j * (i - 1) * TAU)
        c = a + radius * np.exp(1j * (pin_dir * (i - 1) * TAU + phi2))
        b = circle_point(o, L3, c, L2P, -branches[i - 1])
        theta.append(np.angle(b - o))
    return np.array(theta)


def rocker_speeds(radius, branches, pin_dir=1, phi=PHI):
    """ω_k = ω1·dθ_k/dφ by central differences (rad/s); NaN where a chain cannot assemble."""
    d = rocker_angles(phi + H, radius, branches, pin_dir) - rocker_angles(phi - H, radius,
                                                                         branches, pin_dir)
    return W1 * ((d + np.pi) % (2 * np.pi) - np.pi) / (2 * H)


# ----------------------------------------------------------------------------- paper eq. (8)
def arctan(z):
    """The paper's arctg(y/x): principal value only, quadrant lost."""
    return np.arctan(z.imag / z.real)


def paper_eq8(radius, v_radius, plan_offset, gamma_fn, psi_fn, sign):
    """ω_k from eqs. (1)-(8) as printed (eq. (1) and cos β_i with their typos corrected)."""
    a = L1 * np.exp(1j * PHI)
    b1 = circle_point(a, L2, L0 + 0j, L3, 1)
    phi2, phi3 = np.angle(b1 - a), np.angle(b1 - L0)
    v_a = W1 * L1
    v_b1 = v_a * np.sin(PHI - phi2) / np.sin(phi3 - phi2)
    v_b1a = v_a * np.sin(phi3 - PHI) / np.sin(phi3 - phi2)
    omega = [v_b1 / L3]
    for i in range(2, N + 1):
        ang = (i - 1) * TAU
        d = L0 * np.exp(1j * ang) - (a + radius * np.exp(1j * (ang + phi2)))
        co = np.abs(d)
        alpha = np.arccos((L3**2 + L2P**2 - co**2) / (2 * L3 * L2P))
        beta = np.arccos((co**2 + L3**2 - L2P**2) / (2 * co * L3))
        theta = np.pi - beta + gamma_fn(d)
        v_c = v_a * np.exp(1j * PHI) + v_b1a * v_radius / L2 * np.exp(1j * (ang + phi2
                                                                             + plan_offset))
        omega.append(sign * np.abs(v_c) * np.sin(theta - psi_fn(v_c) - alpha) / np.sin(alpha)
                     / L3)
    return np.array(omega)


# ----------------------------------------------------------------------------- sections
def paper_arithmetic() -> None:
    print("A. The paper's own arithmetic")
    for stroke, (hi, lo, avg, delta) in PAPER.items():
        print(f"  {stroke:8s} (max+min)/2 = {(hi + lo) / 2:.2f} (paper {avg}),  "
              f"(max-min)/ω_cp = {(hi - lo) / avg:.4f} (paper {delta}),  max/min = {hi / lo:.4f}")
    print(f"  reverse δ / forward δ = {0.397 / 0.376:.3f} (conclusion 2: 'about 5 %')")


def exact_model() -> None:
    section("B. optdesign exact evaluator (ω1 = 97)")
    values = dict(l0=L0, l1=L1, l2=L2, l2_prime=L2P, l3=L3, phases=N)
    print(row("paper's table", PAPER["forward"], PAPER["reverse"]))
    for layout in ("collinear", "text"):
        d = Design("fourbar_converter", values, {"pin_layout": layout})
        f, r = (exact_figures(d, s, W1)[0] for s in ("forward", "reverse"))
        print(row(f"pin_layout={layout}", (f.omega_max, f.omega_min, f.omega_midrange, f.delta),
                  (r.omega_max, r.omega_min, r.omega_midrange, r.delta)))
        print(row(f"pin_layout={layout}, ω_avg = time mean",
                  (f.omega_max, f.omega_min, f.omega_mean, f.delta_mean),
                  (r.omega_max, r.omega_min, r.omega_mean, r.delta_mean)))


def best_of(candidates):
    """(name, fwd, rev) with the lowest err* among finite candidates."""
    finite = [c for c in candidates if np.isfinite(c[1][0]) and np.isfinite(c[2][0])]
    return min(finite, key=lambda c: (errors(c[1], c[2])[1], errors(c[1], c[2])[0]))


def geometric_readings() -> None:
    section("C. Geometric readings (numpy, ω1 = 97)")
    for radius, label in ((L2 - L2P, "|AC|=l2-l2'"), (L2P, "|AC|=l2' (eq. 2)")):
        for pin_dir, pins in ((1, ""), (-1, ", pins numbered the other way")):
            w = rocker_speeds(radius, [1] * N, pin_dir)
            if not np.isfinite(w).all():
                print(f"{label + pins:<52s} | does not assemble on the left branch")
                continue
            fwd, rev = both_strokes(w)
            print(row(label + pins, fwd, rev))
        w = rocker_speeds(radius, [1] * N)
        fwd, rev = both_strokes(w)
        print(row(label + ", crank turned the other way", rev, fwd))
        print(row(label + ", ω_avg = time mean", *both_strokes(w, mean=True)))
        print(row(label + ", best of 64 branch combinations", *best_of(branch_candidates(
            radius))[1:]))
        print(row(label + ", best of 63 chain subsets", *best_of(subset_candidates(radius))[1:]))
        print(row(label + ", chains 2..6 only (rockers 5..13)", *both_strokes(w[1:])))


def branch_candidates(radius):
    speeds = {(b1, bk): rocker_speeds(radius, [b1] + [bk] * (N - 1)) for b1 in (1, -1)
              for bk in (1, -1)}
    for b1 in (1, -1):
        for rest in itertools.product((1, -1), repeat=N - 1):
            w = np.vstack([speeds[b1, 1][0]] + [speeds[b1, b][k + 1]
                                                for k, b in enumerate(rest)])
            if np.isfinite(w).all():
                yield (b1,) + rest, *both_strokes(w)


def subset_candidates(radius):
    w = rocker_speeds(radius, [1] * N)
    for mask in range(1, 2**N):
        rows = [k for k in range(N) if mask >> k & 1]
        yield rows, *both_strokes(w[rows])


def paper_formula_readings() -> None:
    section("D. The paper's eq. (8) to the letter: |AC|, v_CA scale, plan axis, γ, ψ, sign of (8)")
    dead = []
    fns = {"atan2": np.angle, "arctan": arctan}
    for radius, v_radius in ((L2 - L2P, L2 - L2P), (L2 - L2P, L2P), (L2P, L2P)):
        for plan, plan_name in ((0.0, "φ2"), (np.pi, "180+φ2")):
            for (gn, gf), (pn, pf) in itertools.product(fns.items(), repeat=2):
                for sign in (1, -1):
                    w = paper_eq8(radius, v_radius, plan, gf, pf, sign)
                    name = (f"{radius:.0f},{v_radius:.0f}/225,{plan_name},γ {gn},ψ {pn},"
                            f"{'+' if sign > 0 else '-'}")
                    fwd, rev = both_strokes(w)
                    if min(fwd[1], rev[1]) > 0:
                        print(row(name, fwd, rev))
                    else:
                        dead.append(name)
    print(f"  + {len(dead)} more readings (all with an arctan) whose envelope drops to 0 on "
          "one stroke: arctan flips the sign of ω_k on part of the turn")


def radius_scan() -> None:
    section("E. Pin radius |AC_i| scanned (left branch, ω1 = 97)")
    phi = PHI[::8]
    for radius in np.arange(100.0, 151.0, 5.0):
        w = rocker_speeds(radius, [1] * N, phi=phi)
        print(row(f"|AC| = {radius:.0f} mm", *both_strokes(w)))


def main() -> None:
    warnings.filterwarnings("ignore", category=RuntimeWarning)
    paper_arithmetic()
    exact_model()
    geometric_readings()
    paper_formula_readings()
    radius_scan()


if __name__ == "__main__":
    main()

"""Error against run time of every evaluator of the output envelope (``optdesign bench accuracy``).

Four ways to get δ, the ratio and ω_min of one design (docs/formulation.md):

* ``sampled``: :func:`optdesign.envelope.sampled.sampled_figures` at N equally spaced crank angles;
* ``exact``: :func:`optdesign.envelope.exact.exact_figures` (crossings and stationary points by Brent),
  with a coarser or finer search grid ``n_grid``;
* ``surrogate``: the NLP's own view (:mod:`optdesign.solver.nlp`) at the design with its lengths
  held fixed: IPOPT moves only the envelope variables (w_hi, w_lo, the peak and hand-over
  angles), so ``PhaseNLP.surrogate`` returns what the optimiser believes of that design, for
  ``samples`` N and log-sum-exp smoothing ρ;
* ``lse``: a plain log-sum-exp formulation without the NLP's exact hand-over and peak points:
  ω_max the sampled maximum, ω_min = min_j LSE_ρ(f(φ_j)), mean = mean_j LSE_ρ(f(φ_j)). It shows
  what the hand-over points buy.

Each is compared with a tight reference: the exact evaluator on a 16384-point grid, optionally
cross-checked by a chunked sampled evaluation on 2·10^6 crank angles. Errors are absolute for δ
and the ratio (both dimensionless), relative for ω_min.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace

import numpy as np

from optdesign.envelope.exact import DEFAULT_GRID, exact_figures
from optdesign.envelope.sampled import (StrokeFigures, driving_speeds, output_envelope,
                                        sampled_figures)
from optdesign.evaluation.design import Design
from optdesign.figures.design import place_labels, pyplot
from optdesign.lifetime import interrupts_kept
from optdesign.quantities.criteria import objective_of
from optdesign.solver import solve, verify
from optdesign.solver.phase_solver import PhaseSolver
from optdesign.solver.verify import start_guess

REFERENCE_GRID = 16384
SAMPLED_N = (16, 32, 64, 90, 128, 256, 512, 1024, 4096, 16384, 65536)
EXACT_GRID = (8, 16, 32, 64, 128, 256, 1024, 4096)
SURROGATE_N = (30, 45, 60, 90, 180, 360)
SMOOTHING = (50.0, 200.0, 1000.0)
#: (samples, smoothing) pairs of the full solves, and the tightest one (SOLVE_REFERENCE); each
#: verified optimum is measured against the best of them
SOLVE_SETTINGS = ((30, 200.0), (45, 200.0), (90, 50.0), (90, 200.0), (90, 1000.0),
                  (180, 200.0))
SOLVE_QUICK = ((45, 200.0), (90, 200.0))
SOLVE_REFERENCE = (360, 200.0)


@dataclass(frozen=True)
class Reference:
    figures: StrokeFigures
    method: str
    crosscheck: dict | None = None


def chunked_sampled_figures(design, stroke: str, input_speed: float, n_samples: int,
                            eccentricity: float = 1.0, chunk: int = 1 << 17) -> StrokeFigures:
    """:func:`sampled_figures` in chunks, so 10^6 and more samples fit in memory."""
    phi = np.linspace(0.0, 2 * np.pi, n_samples, endpoint=False)
    hi, lo, total = -math.inf, math.inf, 0.0
    for start in range(0, n_samples, chunk):
        part = phi[start:start + chunk]
        env = output_envelope(design.sample(part, eccentricity)["dtheta"], stroke)
        hi, lo, total = max(hi, env.max()), min(lo, env.min()), total + env.sum()
    w1 = input_speed
    return StrokeFigures.from_extremes(hi * w1, lo * w1, total / n_samples * w1, w1)


def reference_figures(design, stroke, input_speed, eccentricity=1.0,
                      crosscheck_samples: int = 0) -> Reference:
    """Exact figures on a 16384-point grid; with ``crosscheck_samples`` also the sampled
    figures on that many angles and their differences (O(h) at the kinks, so ~1e-6 at 2·10^6)."""
    fig, _ = exact_figures(design, stroke, input_speed, eccentricity, n_grid=REFERENCE_GRID)
    method = f"exact evaluator, n_grid = {REFERENCE_GRID}"
    check = None
    if crosscheck_samples:
        t0 = time.perf_counter()
        s = chunked_sampled_figures(design, stroke, input_speed, crosscheck_samples,
                                    eccentricity)
        check = {"samples": crosscheck_samples, "time_s": time.perf_counter() - t0,
                 **_errors(s, fig), "sampled_minus_exact_delta": s.delta - fig.delta}
    return Reference(fig, method, check)


def _errors(fig: StrokeFigures, ref: StrokeFigures) -> dict:
    return {"delta_error": abs(fig.delta - ref.delta),
            "ratio_error": abs(fig.ratio - ref.ratio),
            "omega_min_error": abs(fig.omega_min - ref.omega_min) / ref.omega_min
            if ref.omega_min > 0 else abs(fig.omega_min),
            "delta_signed": fig.delta - ref.delta}


def _timed(fn, min_time: float = 0.05, max_repeats: int = 50):
    """(result, seconds per call): repeated until ``min_time`` has passed, best of the calls."""
    best, out, spent, n = math.inf, None, 0.0, 0
    while n < max_repeats and (n == 0 or spent < min_time):
        t0 = time.perf_counter()
        out = fn()
        dt = time.perf_counter() - t0
        best, spent, n = min(best, dt), spent + dt, n + 1
    return out, best


# --------------------------------------------------------------------------- evaluators
def sampled_rows(design, stroke, input_speed, ref: Reference, samples=SAMPLED_N, e=1.0,
                 progress=None):
    rows = []
    for n in samples:
        fig, t = _timed(lambda: chunked_sampled_figures(design, stroke, input_speed, n, e)
                        if n > 65536 else sampled_figures(design, stroke, input_speed, n, e))
        rows.append({"method": "sampled", "samples": n, "smoothing": None, "time_s": t,
                     **_errors(fig, ref.figures)})
        _tick(progress)
    return rows


def exact_rows(design, stroke, input_speed, ref: Reference, grids=EXACT_GRID, e=1.0,
               progress=None):
    rows = []
    for n in grids:
        fig, t = _timed(lambda: exact_figures(design, stroke, input_speed, e, n_grid=n)[0])
        rows.append({"method": "exact", "samples": n, "smoothing": None, "time_s": t,
                     **_errors(fig, ref.figures)})
        _tick(progress)
    return rows


def lse_figures(design, stroke, input_speed, n_samples, rho, e=1.0) -> StrokeFigures:
    """The plain log-sum-exp formulation (no exact hand-over or peak points), see module doc."""
    phi = np.linspace(0.0, 2 * np.pi, n_samples, endpoint=False)
    f = driving_speeds(design.sample(phi, e)["dtheta"], stroke)
    top = f.max(axis=0)
    lse = top + np.log(np.exp(rho * (f - top)).sum(axis=0)) / rho
    w1 = input_speed
    return StrokeFigures.from_extremes(top.max() * w1, lse.min() * w1, lse.mean() * w1, w1)


def lse_rows(design, stroke, input_speed, ref: Reference, samples=SURROGATE_N,
             smoothings=SMOOTHING, e=1.0, progress=None):
    rows = []
    for rho in smoothings:
        for n in samples:
            fig, t = _timed(lambda: lse_figures(design, stroke, input_speed, n, rho, e))
            rows.append({"method": "lse", "samples": n, "smoothing": rho, "time_s": t,
                         **_errors(fig, ref.figures)})
            _tick(progress)
    return rows


def surrogate_figures(problem, values, samples: int, smoothing: float):
    """The NLP's view of one fixed design: (StrokeFigures at e = 1, inner solve time, time of
    one evaluation of the NLP's constraints and their Jacobian, IPOPT status)."""

    fixed = problem.with_values(values)
    fixed = replace(fixed, solver=replace(problem.solver, samples=samples, smoothing=smoothing),
                    objective=replace(problem.objective, minimize="ripple", robust="none"),
                    constraints=replace(problem.constraints, bounds=tuple(
                        b for b in problem.constraints.bounds
                        if b.name == "transmission_angle" and b.at is None)),
                    eccentricities=(1.0,), eccentricity_range=None)
    count = int(round(values[problem.model.count_variable]))
    solver = PhaseSolver(fixed, count)
    ver = solver.verify(fixed, values)
    if not ver.sequences:
        from optdesign.errors import SolveError
        raise SolveError(f"the NLP cannot evaluate this design: {ver.message}")
    nlp = solver.nlp(ver.sequences)
    guess = start_guess(nlp, ver)
    lbx, ubx = nlp.bounds(guess, ver.sequences)
    params = nlp.parameters(ver.sequences)
    x0 = nlp.start(guess, lbx, ubx, params)
    lbg, ubg = nlp.constraint_bounds(fixed, ver.sequences)
    ipopt = nlp.solver(fixed.solver.hessian)
    t0 = time.perf_counter()
    with interrupts_kept():                 # CasADi swallows a Ctrl-C during IPOPT
        sol = ipopt(x0=x0, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg, p=params)
    t_solve = time.perf_counter() - t0
    status = ipopt.stats()["return_status"]
    x = np.array(sol["x"]).ravel()
    ripples, means, peaks = (np.array(v).ravel() for v in nlp.surrogate(x, params))
    w_hi, w_lo = x[nlp.layout.find(nlp.layout.x, "w_e1")]
    jac = ipopt.get_function("nlp_jac_g")
    _, t_eval = _timed(lambda: jac(x, params), min_time=0.02)
    w1 = problem.input_speed
    fig = StrokeFigures.from_extremes(w_hi * w1, w_lo * w1, means[0] * w1, w1)
    return fig, t_solve, t_eval, status


def surrogate_rows(problem, values, ref: Reference, samples=SURROGATE_N, smoothings=SMOOTHING,
                   progress=None):
    rows = []
    for rho in smoothings:
        for n in samples:
            fig, t_solve, t_eval, status = surrogate_figures(problem, values, n, rho)
            rows.append({"method": "surrogate", "samples": n, "smoothing": rho,
                         "time_s": t_solve, "eval_time_s": t_eval, "ipopt_status": status,
                         **_errors(fig, ref.figures)})
            _tick(progress)
    return rows


def solve_rows(problem, settings=SOLVE_SETTINGS, reference=SOLVE_REFERENCE, progress=None):
    """Full solves of ``problem`` at several (samples, smoothing), ``reference`` (the tightest)
    first: run time, and each verified optimum's δ and ratio against the best of them."""
    runs = []
    for n, rho in (reference,) + tuple(settings):
        p = replace(problem, solver=replace(problem.solver, samples=n, smoothing=rho))
        r = solve(p)
        ok = r.status == "optimal" and verify(p, r.design).feasible
        runs.append((n, rho, r, ok))
        _tick(progress)
    # Reference: the best verified optimum of every setting (the tightest one included): a
    # multistart may stop at a slightly worse local optimum, whatever its sampling.
    verified = [r for _, _, r, ok in runs if ok]
    rank = objective_of(problem).rank
    ref = min(verified, key=lambda r: rank(r.delta, r.ratio)) if verified else runs[0][2]
    rows = []
    for n, rho, r, ok in runs:
        gap = r.best_phase().surrogate_gap if r.best_phase() else None
        rows.append({"method": "solve", "samples": n, "smoothing": rho,
                     "tightest": (n, rho) == tuple(reference),
                     "time_s": r.solve_time_s, "status": r.status, "verified": ok,
                     "delta": r.delta, "ratio": r.ratio, "surrogate_gap": gap,
                     "delta_error": abs(r.delta - ref.delta) if ok and ref.delta else None,
                     "ratio_error": abs(r.ratio - ref.ratio) if ok and ref.ratio else None,
                     "reference_delta": ref.delta, "iterations": r.iterations,
                     "angle_sample_gap_deg": r.accuracy["transmission_angle_sample_gap_deg"],
                     "starts": sum(len(ph.starts) for ph in r.per_phase)})
    return rows


def _settings(quick: bool, e: float, solve: bool) -> dict:
    """What the benchmark evaluates: {part: its settings}, in the order it runs them."""
    parts = {"sampled": SAMPLED_N[:-2] if quick else SAMPLED_N,
             "exact": (8, 64, DEFAULT_GRID) if quick else EXACT_GRID}
    if e == 1.0:
        parts["surrogate_samples"] = (45, 90) if quick else SURROGATE_N
        parts["surrogate_smoothing"] = (200.0,) if quick else SMOOTHING
    if solve:
        parts["solve"] = (SOLVE_REFERENCE,) + (SOLVE_QUICK if quick else SOLVE_SETTINGS)
    return parts


def evaluation_count(e: float = 1.0, quick: bool = False, solve: bool = False) -> int:
    """How many evaluations :func:`accuracy_rows` reports to its ``progress``: the reference,
    one per sampled and exact setting, per (samples, ρ) of the log-sum-exp formulation and of
    the surrogate, and one per full solve."""
    parts = _settings(quick, e, solve)
    n = 1 + len(parts["sampled"]) + len(parts["exact"]) + len(parts.get("solve", ()))
    if e == 1.0:
        n += len(parts["surrogate_samples"]) * (len(SMOOTHING)
                                                + len(parts["surrogate_smoothing"]))
    return n


def _tick(progress) -> None:
    if progress is not None:
        progress(1)


def accuracy_rows(problem, values=None, e: float = 1.0, crosscheck_samples: int = 0,
                  solve_problem=None, quick: bool = False,
                  progress=None) -> tuple[list[dict], Reference]:
    """Every row of the benchmark for the problem's design (at its fixed / initial values).

    ``progress``, if given, is called with 1 after each of the :func:`evaluation_count`
    evaluations (e.g. a tqdm bar's ``update``).
    """
    design = Design.from_problem(problem, values)
    design.check_assembly(e)
    args = (design, problem.stroke, problem.input_speed)
    parts = _settings(quick, e, solve_problem is not None)
    ref = reference_figures(*args, e, crosscheck_samples)
    _tick(progress)
    rows = sampled_rows(*args, ref, parts["sampled"], e, progress) + \
        exact_rows(*args, ref, parts["exact"], e, progress)
    if e == 1.0:
        nsur = parts["surrogate_samples"]
        rows += lse_rows(*args, ref, nsur, progress=progress)
        rows += surrogate_rows(problem, dict(design.values), ref, nsur,
                               parts["surrogate_smoothing"], progress)
    if solve_problem is not None:
        rows += solve_rows(solve_problem, parts["solve"][1:], progress=progress)
    return rows, ref


# --------------------------------------------------------------------------- presenting
def format_table(rows: list[dict], ref: Reference) -> str:
    f = ref.figures
    lines = [f"reference: {ref.method}: δ = {f.delta:.12g}, ratio = {f.ratio:.12g}, "
             f"ω_min = {f.omega_min:.12g} rad/s"]
    if ref.crosscheck:
        c = ref.crosscheck
        lines.append(f"cross-check: sampled at {c['samples']} angles differs by "
                     f"δ {c['delta_error']:.2e}, ratio {c['ratio_error']:.2e}, "
                     f"ω_min {c['omega_min_error']:.2e} (relative)")
    lines.append(f"{'method':<10} {'N':>6} {'ρ':>6} {'δ error':>9} {'ratio err':>9} "
                 f"{'ω_min err':>9} {'time [s]':>9}")
    for r in rows:
        rho = "" if r.get("smoothing") is None else f"{r['smoothing']:g}"
        cells = [_sci(r.get(k)) for k in ("delta_error", "ratio_error", "omega_min_error")]
        extra = ""
        if r["method"] == "solve":
            extra = f"  {r['status']}, δ = {r['delta']:.6f}" if r["delta"] is not None else \
                f"  {r['status']}"
        lines.append(f"{r['method']:<10} {r['samples']:>6} {rho:>6} {cells[0]:>9} "
                     f"{cells[1]:>9} {cells[2]:>9} {r['time_s']:9.2e}{extra}")
    return "\n".join(lines)


def _sci(v) -> str:
    return "-" if v is None else f"{v:.2e}"


def plot_accuracy(rows: list[dict], ax=None, title: str | None = None):
    """δ error against run time, log-log, one line per method (and per ρ); returns the figure.

    Points are labelled with their sample count where the label overlaps no other label or
    marker: each line's smallest and largest count first, then the others while room is left.
    """
    plt = pyplot()
    fig, ax = (ax.figure, ax) if ax is not None else plt.subplots(figsize=(8.5, 5.6))
    floor = 1e-16
    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        if r.get("delta_error") is None:
            continue
        key = (r["method"], None if r["method"] == "solve" else r.get("smoothing"))
        groups.setdefault(key, []).append(r)
    styles = {"sampled": ("o", "-"), "exact": ("s", "-"), "surrogate": ("^", "--"),
              "lse": ("v", ":"), "solve": ("D", "")}
    labels = []                     # (priority, (x, y), text, colour)
    for (method, rho), rs in groups.items():
        rs = sorted(rs, key=lambda r: r["time_s"])
        marker, ls = styles.get(method, ("x", "-"))
        t = [r["time_s"] for r in rs]
        err = [max(r["delta_error"], floor) for r in rs]
        line, = ax.plot(t, err, marker=marker, ls=ls or "none", label=_label(method, rho),
                        ms=5)
        if method in ("sampled", "exact", "surrogate", "solve"):
            counts = [r["samples"] for r in rs]
            ends = {counts.index(min(counts)), counts.index(max(counts))}
            for j, (r, x, y) in enumerate(zip(rs, t, err)):
                text = str(r["samples"]) if method != "solve" else \
                    f"N={r['samples']}, ρ={r['smoothing']:g}"
                labels.append((0 if j in ends else 1, (x, y), text, line.get_color()))
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("run time per evaluation (per solve for full solves) [s]")
    ax.set_ylabel("|δ - δ_reference|  (errors below 1e-16 drawn at 1e-16)")
    ax.set_title(title or "Ripple error against run time")
    ax.grid(True, which="major", alpha=0.35)
    ax.legend(fontsize=7.5, loc="center left", bbox_to_anchor=(1.01, 0.5), frameon=False,
              title="method (labels: samples N)", title_fontsize=8)
    fig.tight_layout()
    if labels:
        labels.sort(key=lambda item: item[0])
        markers = np.array([xy for line in ax.get_lines() for xy in line.get_xydata()])
        place_labels(ax, [xy for _, xy, _, _ in labels], [t for _, _, t, _ in labels],
                     colors=[c for _, _, _, c in labels], avoid=markers, force=False,
                     fontsize=7, distance=4)
    return fig


def _label(method: str, rho) -> str:
    if method == "surrogate":
        return f"NLP surrogate, ρ = {rho:g} (inner IPOPT solve)"
    if method == "lse":
        return f"plain log-sum-exp, ρ = {rho:g}"
    return {"sampled": "sampled, N samples", "exact": "exact, n_grid",
            "solve": "full solves (δ minus the best solve's δ)"}.get(method, method)

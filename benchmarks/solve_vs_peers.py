"""IPOPT against differential evolution and a genetic algorithm on the same problem.

Same model (the mechanism's one CasADi function), same constraints (transmission angle at
every sample, pin radius, ratio), same bounds. The peers see the envelope on N crank samples
(the natural black-box objective); every optimum, ours included, is then re-evaluated by the
exact evaluator, and that is the δ the table reports.

    python benchmarks/solve_vs_peers.py [PROBLEM.yaml] [--samples N] [--seed S] [--quick]

Prints a table: method, exact δ, ratio, worst constraint violation, in-process time,
function evaluations (IPOPT: NLP iterations, each with exact first and second derivatives).
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from optdesign.design import Design  # noqa: E402
from optdesign.envelope import output_envelope  # noqa: E402
from optdesign.problem import load_problem  # noqa: E402
from optdesign.solve import solve, verify  # noqa: E402


class SampledModel:
    """δ, ratio and the constraints of a design from N crank samples (what the peers see)."""

    def __init__(self, problem, samples: int):
        self.problem = problem
        self.count = problem.counts()[0]
        self.free = problem.free_lengths()
        self.lower = np.array([problem.design[k].lower for k in self.free])
        self.upper = np.array([problem.design[k].upper for k in self.free])
        self.phi = np.linspace(0, 2 * math.pi, samples, endpoint=False)
        c = problem.constraints
        self.cos_limit = math.cos(math.radians(c.min_transmission_angle_deg))
        self.nfev = 0

    def values(self, x) -> dict:
        return self.problem.start_values() | dict(zip(self.free, x)) | {
            self.problem.model.count_variable: self.count}

    def evaluate(self, x) -> tuple[float, np.ndarray]:
        """(δ, g) with every g <= 0 when satisfied; non-assembly gives a large finite δ."""
        self.nfev += 1
        P = self.problem
        design = Design.from_problem(P, self.values(x))
        out = design.sample(self.phi)
        env = output_envelope(out["dtheta"], P.stroke)
        hi, lo, mean = env.max(), env.min(), env.mean()
        delta = (hi - lo) / (0.5 * (hi + lo)) if P.objective.ripple == "midrange" else \
            (hi - lo) / mean
        lengths = {k: design.values[k] for k in P.model.lengths}
        g = [float(np.max(np.abs(out["cos_mu"]))) - self.cos_limit,
             P.objective.min_ratio - mean]
        g += [-float(v) for _, v in P.model.design_constraints(lengths, self.count, P.constraints)]
        if not np.all(np.isfinite(out["cos_mu"])) or not math.isfinite(delta):
            return 10.0, np.full(len(g), 10.0)
        return float(delta), np.array(g)


def run_ipopt(problem):
    t0 = time.perf_counter()
    result = solve(problem)
    elapsed = time.perf_counter() - t0
    return result.design, elapsed, f"{result.iterations} iterations"


def run_de(model, seed, maxiter):
    from scipy.optimize import NonlinearConstraint, differential_evolution

    cache = {}

    def ev(x):
        key = tuple(x)
        if key not in cache:
            cache.clear()
            cache[key] = model.evaluate(x)
        return cache[key]

    g_size = ev(0.5 * (model.lower + model.upper))[1].size
    con = NonlinearConstraint(lambda x: ev(x)[1], -np.inf, np.zeros(g_size))
    model.nfev = 0
    t0 = time.perf_counter()
    res = differential_evolution(lambda x: ev(x)[0], list(zip(model.lower, model.upper)),
                                 constraints=(con,), seed=seed, maxiter=maxiter, popsize=15,
                                 tol=1e-10, atol=0, polish=False, init="sobol",
                                 updating="deferred")
    elapsed = time.perf_counter() - t0
    return model.values(res.x), elapsed, f"{model.nfev} evaluations"


def run_ga(model, seed, n_gen):
    from pymoo.algorithms.soo.nonconvex.ga import GA
    from pymoo.core.problem import ElementwiseProblem
    from pymoo.optimize import minimize

    n_g = model.evaluate(0.5 * (model.lower + model.upper))[1].size

    class Converter(ElementwiseProblem):
        def __init__(self):
            super().__init__(n_var=len(model.free), n_obj=1, n_ieq_constr=n_g,
                             xl=model.lower, xu=model.upper)

        def _evaluate(self, x, out, *args, **kwargs):
            out["F"], out["G"] = model.evaluate(x)

    model.nfev = 0
    t0 = time.perf_counter()
    res = minimize(Converter(), GA(pop_size=60), ("n_gen", n_gen), seed=seed, verbose=False)
    elapsed = time.perf_counter() - t0
    x = res.X if res.X is not None else res.pop.get("X")[0]
    return model.values(np.atleast_1d(x)), elapsed, f"{model.nfev} evaluations"


def worst_violation(ver) -> float:
    finite = [v for v in ver.violations.values() if math.isfinite(v)]
    if len(finite) < len(ver.violations):
        return math.inf
    return max(finite, default=0.0)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("problem", nargs="?", default=str(ROOT / "problems" /
                                                          "sharkov2022_disc.yaml"))
    parser.add_argument("--samples", type=int, default=360, help="crank samples for the peers")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--quick", action="store_true", help="short peer runs (smoke test)")
    args = parser.parse_args(argv)
    problem = load_problem(args.problem)
    if len(problem.counts()) != 1:
        print("the benchmark takes a problem with one phase count", file=sys.stderr)
        return 2
    model = SampledModel(problem, args.samples)
    runs = [("IPOPT (optdesign)", lambda: run_ipopt(problem))]
    de_iter, ga_gen = (20, 20) if args.quick else (400, 400)
    runs.append((f"differential_evolution (N={args.samples})",
                 lambda: run_de(model, args.seed, de_iter)))
    runs.append((f"pymoo GA (N={args.samples})", lambda: run_ga(model, args.seed, ga_gen)))
    rows = []
    for name, run in runs:
        values, elapsed, evals = run()
        ver = verify(problem, values)
        rows.append((name, ver.delta, ver.ratio, worst_violation(ver), elapsed, evals))
    ours = rows[0][4]
    print(f"problem: {problem.name} ({args.problem}); exact δ of every optimum")
    print(f"| method | exact δ | ratio | worst violation | time [s] | time / IPOPT | work |")
    print(f"|---|---|---|---|---|---|---|")
    for name, delta, ratio, viol, elapsed, evals in rows:
        print(f"| {name} | {delta:.6f} | {ratio:.4f} | {viol:.2g} | {elapsed:.2f} | "
              f"{elapsed / ours:.1f} | {evals} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())

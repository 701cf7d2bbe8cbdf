"""Multi-start IPOPT over every admissible phase count, each optimum re-verified exactly."""
from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np

from ..accuracy import solve_accuracy
from ..design import Design
from .nlp import PhaseNLP
from .result import PhaseResult, SolveResult, StartRecord
from .starts import start_designs
from .verify import Verification, eccentricities_of, verify

SUCCESS = ("Solve_Succeeded", "Solved_To_Acceptable_Level")
MAX_REFINEMENTS = 4
ANGLE_SAFETY_DEG = 0.01
#: two optima "agree" within this relative difference (the multistart stopping rule)
AGREE_REL = 1e-4


class PhaseSolver:
    """Solves the NLP of one phase count from any start; keeps the built NLPs for re-use
    (warm starts along a sweep re-solve the same NLP with other parameters)."""

    def __init__(self, problem, count: int):
        self.problem = problem
        self.count = count
        self._nlps: dict = {}

    def nlp(self, sequences, extra_angle: float, hessian: str | None = None) -> PhaseNLP:
        hessian = hessian or self.problem.solver.hessian
        key = (sequences, round(extra_angle, 6), hessian)
        if key not in self._nlps:
            c = self.problem.constraints
            mu = min(c.min_transmission_angle_deg + extra_angle, 89.0) if \
                c.min_transmission_angle_deg > 0 else 0.0
            tightened = replace(self.problem, constraints=replace(
                c, min_transmission_angle_deg=mu), solver=replace(self.problem.solver,
                                                                   hessian=hessian))
            self._nlps[key] = PhaseNLP(tightened, self.count, sequences)
        return self._nlps[key]

    def guess(self, nlp: PhaseNLP, ver: Verification, values: dict) -> dict:
        """Initial values of every NLP variable from the exact evaluation of a design."""
        design = Design.from_problem(self.problem, values)
        w1 = self.problem.input_speed
        guess = {"lengths": [values[k] / s for k, s in zip(nlp.free, nlp.scale)],
                 "worst_ripple": [ver.delta]}
        for i, e in enumerate(nlp.eccs):
            tag = f"e{e:g}"
            fig = ver.figures[i]
            guess[f"w_{tag}"] = [fig.omega_max / (w1 * e), fig.omega_min / (w1 * e)]
            dth = design.sample(nlp.phi, e)["dtheta"]
            f = np.vstack([s * dth for s in nlp.signs])
            guess[f"phi_peak_{tag}"] = nlp.phi[np.argmax(f, axis=1)]
            guess[f"phi_handover_{tag}"] = ver.handovers[i]
        return guess

    def solve_from(self, values: dict, min_ratio=None, max_ripple=None,
                   ver: Verification | None = None):
        """IPOPT from one start; refined until the exact check agrees with the NLP's structure.

        Returns (record, verification, values, surrogate δ).
        """
        problem = self.problem
        if min_ratio is not None or max_ripple is not None:
            obj = replace(problem.objective,
                          min_ratio=problem.objective.min_ratio if min_ratio is None else min_ratio,
                          max_ripple=problem.objective.max_ripple if max_ripple is None
                          else max_ripple)
            problem = replace(problem, objective=obj)
        ver = ver or verify(problem, values)
        start = dict(values)
        t0 = time.perf_counter()
        iterations, extra_angle, status, surrogate = 0, ANGLE_SAFETY_DEG, "not run", None
        multiplier = None
        note = ""
        hessian = problem.solver.hessian
        for _ in range(MAX_REFINEMENTS):
            if not ver.sequences:
                note = ver.message
                break
            nlp = self.nlp(ver.sequences, extra_angle, hessian)
            guess = self.guess(nlp, ver, values)
            lbx, ubx = nlp.bounds(guess)
            x0 = np.clip(nlp.pack(guess), lbx, ubx)
            params = nlp.parameters(min_ratio, max_ripple)
            sol = nlp.solver(x0=x0, lbx=lbx, ubx=ubx, lbg=nlp.lbg, ubg=nlp.ubg, p=params)
            stats = nlp.solver.stats()
            status = stats["return_status"]
            iterations += int(stats["iter_count"])
            x = np.array(sol["x"]).ravel()
            # d f*/d lbg = -lam_g (CasADi's sign convention for a lower bound)
            multiplier = -float(np.array(sol["lam_g"]).ravel()[
                nlp.layout.find(nlp.layout.g, "min_ratio")][0])
            at_window = nlp.at_window_bound(x, lbx, ubx)
            trial = values | nlp.lengths_of(x)
            new = verify(problem, trial)
            ripples = np.array(nlp.surrogate(x, params)[0]).ravel()
            listed = [i for i, e in enumerate(nlp.eccs) if e in problem.eccentricities]
            surrogate = float(ripples[listed].max())
            if status == "Maximum_Iterations_Exceeded" and hessian == "limited-memory":
                # The quasi-Newton run stalled: once more from the same start with CasADi's
                # exact Hessian, which converges, or certifies local infeasibility, where
                # L-BFGS wanders (benchmarks/hessian_choice.py).
                hessian = "exact"
                continue
            if status not in SUCCESS:
                note = _binding(nlp, np.array(sol["g"]).ravel())
                values, ver = (trial, new) if new.sequences else (values, ver)
                break
            values, ver = trial, new
            if "transmission_angle" in ver.violations:
                extra_angle += ver.violations["transmission_angle"] + ANGLE_SAFETY_DEG
                continue
            if ver.sequences != nlp.sequences or at_window:
                continue        # hand-overs changed order, or an angle ran to its window
            break
        record = StartRecord(start=start, ipopt_status=status, iterations=iterations,
                             time_s=time.perf_counter() - t0,
                             feasible=bool(ver.feasible and status in SUCCESS),
                             delta=ver.delta, note=note, ratio_multiplier=multiplier)
        return record, ver, values, surrogate


def _binding(nlp: PhaseNLP, g: np.ndarray) -> str:
    """Name of the constraint block most violated at IPOPT's last iterate."""
    viol = np.maximum(nlp.lbg - g, g - nlp.ubg)
    viol[~np.isfinite(viol)] = 0
    if viol.size == 0 or viol.max() <= 1e-6:
        return ""
    i = int(np.argmax(viol))
    return nlp.layout.name_of(nlp.layout.g, i)


def solve_phase(problem, count: int, progress=None) -> PhaseResult:
    """Best verified optimum of one phase count over the multi-start."""
    if not problem.free_lengths():
        fixed = _fixed_infeasible(problem, count)
        if fixed is not None:
            return fixed
    solver = PhaseSolver(problem, count)
    starts = start_designs(problem, count, problem.solver.starts)
    if not starts:
        return PhaseResult(count, "infeasible", binding="assembly",
                           message=f"no design within the bounds assembles at every listed "
                                   f"eccentricity with {count} phases")
    result = PhaseResult(count, "failed")
    best_key, keys = math.inf, []
    for design in starts:
        record, ver, values, surrogate = solver.solve_from(dict(design.values))
        result.starts.append(record)
        result.iterations += record.iterations
        if progress:
            progress()
        if not record.feasible:
            # Stopping rule for infeasible problems: no start feasible, and IPOPT found
            # `agree + 1` of them locally infeasible on this same constraint.
            verdicts = [s.note for s in result.starts
                        if s.ipopt_status == "Infeasible_Problem_Detected"]
            if best_key == math.inf and record.note and \
                    verdicts.count(record.note) >= problem.solver.agree + 1:
                break
            continue
        key = ver.delta if problem.objective.minimize == "ripple" else -ver.ratio
        keys.append(key)
        if key < best_key:
            best_key = key
            result = _fill(result, problem, values, ver, surrogate)
        # Multistart stopping rule: the best optimum has been reached from `agree` starts.
        if sum(abs(k - best_key) <= AGREE_REL * max(1e-3, abs(best_key)) for k in keys) >= \
                problem.solver.agree:
            break
    if result.status != "optimal":
        notes = [s.note for s in result.starts if s.note]
        statuses = {s.ipopt_status for s in result.starts}
        # Infeasible only on IPOPT's word; starts that ran out of iterations prove nothing.
        result.status = "infeasible" if "Infeasible_Problem_Detected" in statuses else "failed"
        result.binding = max(set(notes), key=notes.count) if notes else None
        result.message = (f"no start reached a verified feasible optimum (IPOPT: "
                          f"{', '.join(sorted(statuses))})"
                          + (f"; binding: {result.binding}" if result.binding else ""))
    return result


def _fixed_infeasible(problem, count: int) -> PhaseResult | None:
    """Every length fixed and the exact check fails: nothing for IPOPT to move, so say which
    constraint the design violates (instead of IPOPT failing on the NLP's inner variables)."""
    values = problem.start_values() | {problem.model.count_variable: count}
    ver = verify(problem, values)
    if ver.feasible:
        return None
    names = ", ".join(ver.violations)
    return PhaseResult(count, "infeasible", binding=next(iter(ver.violations), None),
                       message=f"the fixed design violates {names}"
                               + (f" ({ver.message})" if ver.message else ""))


def _fill(result: PhaseResult, problem, values, ver: Verification, surrogate) -> PhaseResult:
    count_key = problem.model.count_variable
    design = {k: float(values[k]) for k in problem.model.lengths}
    design[count_key] = result.phases
    result.status = "optimal"
    result.design = design
    result.delta = ver.delta
    result.ratio = ver.ratio
    result.min_transmission_angle_deg = ver.min_angle_deg
    result.surrogate_delta = surrogate
    result.surrogate_gap = None if surrogate is None else surrogate - ver.delta
    result.regulation = ver.regulation()
    result.message = ""
    return result


def solve(problem, progress=None) -> SolveResult:
    """Solve the problem for every admissible phase count and pick the best verified one."""
    t0 = time.perf_counter()
    per_phase = [solve_phase(problem, n, progress) for n in problem.counts()]
    ok = [p for p in per_phase if p.status == "optimal"]
    if problem.objective.minimize == "ripple":
        best = min(ok, key=lambda p: p.delta, default=None)
    else:
        best = max(ok, key=lambda p: p.ratio, default=None)
    if best:
        status, message = "optimal", ""
    else:
        status = "infeasible" if all(p.status == "infeasible" for p in per_phase) else "failed"
        message = "; ".join(f"n={p.phases}: {p.message}" for p in per_phase)
    accuracy = solve_accuracy(problem, best)        # inside solve_time_s: part of the solve
    return SolveResult(
        name=problem.name, status=status,
        design=best.design if best else None,
        delta=best.delta if best else None,
        ratio=best.ratio if best else None,
        min_transmission_angle_deg=best.min_transmission_angle_deg if best else None,
        solve_time_s=time.perf_counter() - t0,
        iterations=sum(p.iterations for p in per_phase),
        per_phase=per_phase,
        objective={"minimize": problem.objective.minimize, "ripple": problem.objective.ripple,
                   "min_ratio": problem.objective.min_ratio,
                   "max_ripple": problem.objective.max_ripple,
                   "eccentricities": list(problem.eccentricities)},
        accuracy=accuracy,
        message=message, stroke=problem.stroke, mechanism=problem.mechanism,
        input_speed=problem.input_speed)

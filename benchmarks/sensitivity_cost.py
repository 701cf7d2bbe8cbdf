"""Cost of the exact sensitivities of a design (optdesign.evaluation.sensitivity) beside its verification.

For the disc problem's optimum (n = 6, one eccentricity) and the paper's design of
problems/sharkov2022.yaml at n = 6, 12 and 24 (three eccentricities): the median wall time of
one ``sensitivities(problem, values, evaluation)`` call (the evaluation given, as the solver
gives its verification's: the sensitivities read its grid sampling and its runs' stationary
points), of the same call on the evaluation stripped of those (searched again, as before the
evaluation kept them) and of one ``verify(problem, values)`` (the evaluator's memory of the
designs it checked emptied before each call), over ``--repeat`` calls after one warm-up
(CasADi functions built).

    python benchmarks/sensitivity_cost.py [--repeat 15]

Prints a table; writes nothing.
"""
from __future__ import annotations

import argparse
import statistics
from dataclasses import replace
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from optdesign.evaluation.figures import _EVALUATED, evaluate_problem  # noqa: E402
from optdesign.problem.loader import load_problem  # noqa: E402
from optdesign.evaluation.sensitivity import sensitivities  # noqa: E402
from optdesign.solver.verify import verify  # noqa: E402

#: the disc problem's optimum (tests/solve/test_regression_optima.py pins its δ)
DISC_OPTIMUM = {"l0": 399.97641497248475, "l1": 20.0, "l2": 399.99999997792696,
                "l2_prime": 274.99999996642566, "l3": 26.860381817186937, "phases": 6}


def median_ms(call, repeat: int) -> float:
    call()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        call()
        times.append(time.perf_counter() - t0)
    return 1e3 * statistics.median(times)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=15)
    args = parser.parse_args(argv)
    paper = load_problem(ROOT / "problems" / "sharkov2022.yaml")
    cases = [("sharkov2022_disc optimum", load_problem(ROOT / "problems" /
                                                       "sharkov2022_disc.yaml"), DISC_OPTIMUM)]
    cases += [(f"sharkov2022, n = {n}", paper, paper.start_values() | {"phases": n})
              for n in (6, 12, 24)]
    print("| design | eccentricities | sensitivities, ms | searched again, ms | verify, ms | "
          "sensitivities / verify |")
    print("|---|---|---|---|---|---|")
    for name, problem, values in cases:
        ev = evaluate_problem(problem, values)
        bare = replace(ev, per_e=[replace(x, sampled=None, grid=None,
                                          runs=[replace(r, stationary=None) for r in x.runs])
                                  for x in ev.per_e])
        sens = median_ms(lambda: sensitivities(problem, values, ev), args.repeat)
        again = median_ms(lambda: sensitivities(problem, values, bare), args.repeat)
        ver = median_ms(lambda: (_EVALUATED.clear(), verify(problem, values)), args.repeat)
        print(f"| {name} | {len(ev.per_e)} | {sens:.1f} | {again:.1f} | {ver:.1f} | "
              f"{sens / ver:.2f} |")


if __name__ == "__main__":
    main()

"""The worst eccentricity of a fixed design: the interval search against a 10⁴-point scan.

The design (problems/sharkov2022_disc.yaml's box, n = 6, l0 = 268.48, l1 = 20, l2 = 279.2,
l2_prime = 261.78, l3 = 80.67 mm) has its largest δ strictly inside e in [0.2, 1]. Each of
10 000 equally spaced e is evaluated by the exact evaluator (``optdesign.evaluation.regulation``'s
per-eccentricity figures); the scan's largest δ and its e are stored in
benchmarks/results/regulation_scan.json, against which tests/solve/test_regulation_interval.py
checks ``worst_over_range`` (within 1e-6) without repeating the scan (about 4 minutes).

    python benchmarks/regulation_scan.py [--points 10000]
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from optdesign.evaluation.design import Design  # noqa: E402
from optdesign.outputs.atomic import atomic_write_text  # noqa: E402
from optdesign.problem.loader import load_problem  # noqa: E402
from optdesign.evaluation.regulation import _AtEccentricity, worst_over_range  # noqa: E402

PROBLEM = ROOT / "problems" / "sharkov2022_disc.yaml"
DESIGN = {"l0": 268.48, "l1": 20.0, "l2": 279.2, "l2_prime": 261.78, "l3": 80.67, "phases": 6}
LOWER, UPPER = 0.2, 1.0
OUT = ROOT / "benchmarks" / "results" / "regulation_scan.json"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=10_000)
    args = parser.parse_args(argv)
    problem = load_problem(PROBLEM)
    design = Design.from_problem(problem, DESIGN)
    at = _AtEccentricity(design, problem.stroke, problem.input_speed, "midrange")
    t0 = time.perf_counter()
    es = np.linspace(LOWER, UPPER, args.points)
    deltas = np.array([at(e, "none")[0] for e in es])
    scan_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    worst = worst_over_range(design, problem.stroke, problem.input_speed, "midrange",
                             LOWER, UPPER)
    search_s = time.perf_counter() - t0
    i = int(np.argmax(deltas))
    out = {"design": DESIGN, "lower": LOWER, "upper": UPPER, "points": args.points,
           "scan_worst_eccentricity": float(es[i]), "scan_worst_delta": float(deltas[i]),
           "scan_s": round(scan_s, 1),
           "search_worst_eccentricity": worst.eccentricity, "search_worst_delta": worst.delta,
           "search_evaluations": worst.evaluations, "search_s": round(search_s, 2),
           "search_minus_scan": worst.delta - float(deltas[i])}
    atomic_write_text(OUT, json.dumps(out, indent=2) + "\n")
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()

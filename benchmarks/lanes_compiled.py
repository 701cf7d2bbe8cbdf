"""The lanes compiled to C against the NumPy statements: time per call, and the same bits.

Each mechanism's kinematics (θ, dθ/dφ, d²θ/dφ², cos μ of every chain: the exact evaluator's
grids) and speeds (dθ/dφ and cos μ: the screening) at 6 and 24 phases, called on 1 024
(a design's exact grid), 4 096 (the accuracy record's finer grid) and 40 000 lanes (a
screening's), crank angles and lengths drawn at random (some designs do not assemble), on one
thread and on two (``lanes.threads(2)``, as a solve's screening calls them: the NumPy passes
share the interpreter, the compiled halves run at once). The NumPy statements are the whole
function's :class:`~optdesign.numerics.lanes.Lanes`; the compiled lanes are what the solve
runs (:func:`~optdesign.numerics.angle_lanes.angle_lanes`: a kinematics cut at its atan2,
the angles taken by NumPy between compiled stages). Both run in this process, alternating,
medians of ``--rounds``; "same bits" compares every output of every call. The libraries are built first (the builder
process of ``optdesign warm-up``) into the user's cache.

    python benchmarks/lanes_compiled.py [--rounds 7]

Writes benchmarks/results/lanes_compiled.md and its JSON twin.
"""
from __future__ import annotations

import argparse
import json
import platform
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from optdesign.mechanisms import get_mechanism  # noqa: E402
from optdesign.numerics import c_library, native_lanes, user_cache  # noqa: E402
from optdesign.numerics import lanes as lanes_module  # noqa: E402
from optdesign.numerics.angle_lanes import angle_lanes, lane_functions  # noqa: E402
from optdesign.numerics.lanes import Lanes  # noqa: E402
from optdesign.outputs.atomic import atomic_write_text  # noqa: E402

RESULTS = ROOT / "benchmarks" / "results"
MECHANISMS = ("fourbar_converter", "slotted_lever", "pulse_reducer")
COUNTS = (6, 24)
LANES = (1024, 4096, 40000)


def timed(call, rounds: int) -> tuple[float, list]:
    """(median seconds of ``call()`` over ``rounds``, its last result)."""
    times, out = [], None
    for _ in range(rounds):
        t0 = time.perf_counter()
        out = call()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def measure(name: str, what: str, count: int, rounds: int) -> list[dict]:
    """The rows of one function: one per lane count and thread count."""
    fn = getattr(get_mechanism(name), what)(count, ())
    statements = Lanes(fn)                   # the whole function's NumPy statements
    statements.native = None
    lanes = angle_lanes(fn)                  # cut at its atan2, where it has any
    if lanes.native is None:
        return []
    rng = np.random.default_rng(count)
    rows = []
    for n in LANES:
        phi = rng.uniform(0.0, 2 * np.pi, (1, n))
        p = rng.uniform(0.3, 3.0, (fn.nnz_in(1), n)) * 100.0
        for threads in (1, 2):
            with lanes_module.threads(threads):
                numpy_s, a = timed(lambda: statements(phi, p), rounds)
                compiled_s, b = timed(lambda: lanes(phi, p), rounds)
            rows.append({"function": fn.name(), "lanes": n, "threads": threads,
                         "numpy_ms": 1e3 * numpy_s, "compiled_ms": 1e3 * compiled_s,
                         "ratio": numpy_s / compiled_s,
                         "same_bits": all(np.array_equal(x, y, equal_nan=True)
                                          for x, y in zip(a, b))})
    return rows


def table(rows: list[dict]) -> str:
    """One line per function and lane count: one thread, then two."""
    lines = ["| function | lanes | NumPy statements [ms] | compiled [ms] | NumPy / compiled | "
             "two threads: NumPy [ms] | compiled [ms] | NumPy / compiled | same bits |",
             "|---|---|---|---|---|---|---|---|---|"]
    for one, two in zip(rows[0::2], rows[1::2]):
        same = one["same_bits"] and two["same_bits"]
        lines.append(f"| {one['function']} | {one['lanes']} | {one['numpy_ms']:.2f} | "
                     f"{one['compiled_ms']:.2f} | {one['ratio']:.1f}× | {two['numpy_ms']:.2f} | "
                     f"{two['compiled_ms']:.2f} | {two['ratio']:.1f}× | "
                     f"{'yes' if same else 'NO'} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--out", type=Path, default=RESULTS / "lanes_compiled.md")
    args = ap.parse_args(argv)
    where = user_cache.folder()
    if where is None or c_library.compiler() is None:
        print("no cache folder of the user's own or no C compiler: nothing to compare",
              file=sys.stderr)
        return 1
    functions = [getattr(get_mechanism(m), w)(c, ()) for m in MECHANISMS
                 for c in COUNTS for w in ("kinematics", "speeds")]
    recipes = [native_lanes.recipe(f, text) for fn in functions for f, text in lane_functions(fn)]
    for rec, path, _, note in c_library.warm_up(recipes, where, 2):
        if path is None:
            print(f"{rec.function.name()}: not compiled ({note})", file=sys.stderr)
    rows = []
    for m in MECHANISMS:
        for c in COUNTS:
            for w in ("kinematics", "speeds"):
                got = measure(m, w, c, args.rounds)
                rows += got
                for r in got:
                    print(f"{r['function']} {r['lanes']} lanes, {r['threads']} thread(s): "
                          f"{r['numpy_ms']:.2f} -> {r['compiled_ms']:.2f} ms "
                          f"({r['ratio']:.1f}x, same bits: {r['same_bits']})", flush=True)
    if not rows:
        print("no function runs compiled on this machine (native_lanes.eligible)",
              file=sys.stderr)
        return 1
    meta = {"time": time.strftime("%Y-%m-%d %H:%M:%S"), "python": platform.python_version(),
            "machine": platform.machine() + " " + platform.system(), "rounds": args.rounds}
    text = (f"Each function's NumPy lanes against its compiled lanes in one process, "
            f"alternating, medians of {args.rounds} calls; crank angles and lengths at random "
            f"(some designs do not assemble); two threads as a solve's screening calls "
            f"them.\n\n" + table(rows) + "\n")
    atomic_write_text(args.out, text)
    atomic_write_text(args.out.with_suffix(".json"),
                      json.dumps({"meta": meta, "rows": rows}, indent=2) + "\n")
    print(f"wrote {args.out} and .json")
    return 0 if all(r["same_bits"] for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())

"""Error against run time of every evaluator: the table and figure of docs/accuracy.md.

Run from the repository root (a few minutes on 2 cores; the 2·10^6-sample cross-check alone
takes ~40 s):

    PYTHONPATH=. python benchmarks/accuracy.py [--out docs/figures] [--no-crosscheck]

Writes OUT/accuracy.png (the paper's design, problems/sharkov2022.yaml, plus full solves of
problems/sharkov2022_disc.yaml), OUT/accuracy_optimum.png (the same evaluators at the disc
problem's optimum) and OUT/accuracy.json (every row), prints both tables, and writes the
tables docs/accuracy.md and docs/benchmarks.md show to benchmarks/results/accuracy.{md,json}
(spliced into the pages by ``python benchmarks/docs.py --splice``).
"""
from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from optdesign.analyses.accuracy import accuracy_rows, format_table, plot_accuracy  # noqa: E402
from optdesign.outputs.atomic import atomic_savefig, atomic_write_json, atomic_write_text  # noqa: E402
from optdesign.problem.loader import load_problem  # noqa: E402

RESULTS = ROOT / "benchmarks" / "results"
#: the rows the pages show of each evaluator, (method, N, ρ); every row is in accuracy.json
SHOWN = {("sampled", n, None) for n in (16, 90, 1024, 16384, 65536)} \
    | {("exact", n, None) for n in (8, 64, 1024, 4096)} \
    | {("lse", 90, rho) for rho in (50.0, 200.0, 1000.0)} | {("lse", 360, 1000.0)} \
    | {("surrogate", 30, 200.0), ("surrogate", 45, 200.0), ("surrogate", 90, 50.0),
       ("surrogate", 90, 200.0), ("surrogate", 90, 1000.0), ("surrogate", 360, 200.0)}


def duration(seconds: float) -> str:
    """A run time as the pages print it: '0.25 ms', '14 ms', '0.27 s', '9.8 s'."""
    if seconds < 1e-3:
        return f"{seconds * 1e3:.2f} ms"
    if seconds < 0.1:
        return f"{seconds * 1e3:.2g} ms" if seconds < 0.01 else f"{seconds * 1e3:.0f} ms"
    return f"{seconds:.2g} s" if seconds < 1 else f"{seconds:.1f} s"


def _sci(v) -> str:
    return "" if v is None else ("0" if v == 0 else f"{v:.1e}")


def evaluator_table(rows: list[dict]) -> list[str]:
    """The shown rows of the evaluators (method, N, ρ, errors, time per evaluation)."""
    out = ["| method | N | ρ | δ error | ratio error | ω_min error | time |",
           "|---|---|---|---|---|---|---|"]
    for r in rows:
        if (r["method"], r["samples"], r.get("smoothing")) not in SHOWN:
            continue
        rho = "" if r.get("smoothing") is None else f"{r['smoothing']:g}"
        out.append(f"| {r['method']} | {r['samples']} | {rho} | {_sci(r['delta_error'])} | "
                   f"{_sci(r['ratio_error'])} | {_sci(r['omega_min_error'])} | "
                   f"{duration(r['time_s'])} |")
    return out


def reference_table(payload: dict) -> list[str]:
    """The reference of each design and its cross-check by dense sampling."""
    out = ["| design | reference | δ | ratio | cross-check samples | δ difference | "
           "ratio difference |", "|---|---|---|---|---|---|---|"]
    for name, part in (("paper (sharkov2022)", payload["paper"]),
                       ("disc optimum (sharkov2022_disc)", payload["optimum"])):
        ref = part["reference"]
        c = ref.get("crosscheck") or {}
        out.append(f"| {name} | {ref['method']} | {ref['delta']:.9f} | {ref['ratio']:.9f} | "
                   f"{c.get('samples', '')} | {_sci(c.get('delta_error'))} | "
                   f"{_sci(c.get('ratio_error'))} |")
    return out


def solve_table(rows: list[dict]) -> list[str]:
    """The full solves of the disc problem at each (samples, ρ)."""
    out = ["| samples | ρ | status | δ | δ error | ratio | time per solve | IPOPT iterations "
           "(starts) |", "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        if r["method"] != "solve":
            continue
        n = f"{r['samples']} (tightest)" if r.get("tightest") else str(r["samples"])
        delta = "" if r["delta"] is None else f"{r['delta']:.7f}"
        ratio = "" if r["ratio"] is None else f"{r['ratio']:.5f}"
        err = "" if r.get("delta_error") is None else f"{r['delta_error']:.1e}"
        out.append(f"| {n} | {r['smoothing']:g} | {r['status']} | {delta} | {err} | {ratio} | "
                   f"{duration(r['time_s'])} | {r['iterations']} ({r['starts']}) |")
    return out


#: the rows docs/benchmarks.md shows: (method, N, ρ) -> its name there; the surrogate at the solve's defaults
README_ROWS = {("sampled", 90, None): "sampled envelope", ("sampled", 16384, None):
               "sampled envelope", ("exact", 1024, None): "exact evaluator (grid)",
               ("lse", 90, 200.0): "plain log-sum-exp",
               ("surrogate", 30, 200.0): "NLP surrogate (ours, inner solve)"}


def readme_table(rows: list[dict]) -> list[str]:
    """The few rows docs/benchmarks.md shows of the paper's design."""
    out = ["| method | N | ρ | δ error | ratio error | time |", "|---|---|---|---|---|---|"]
    for r in rows:
        name = README_ROWS.get((r["method"], r["samples"], r.get("smoothing")))
        if name is not None:
            rho = "" if r.get("smoothing") is None else f"{r['smoothing']:g}"
            out.append(f"| {name} | {r['samples']} | {rho} | {_sci(r['delta_error'])} | "
                       f"{_sci(r['ratio_error'])} | {duration(r['time_s'])} |")
    return out


def results_markdown(payload: dict) -> str:
    """benchmarks/results/accuracy.md: table 1 the references, 2 the paper's design,
    3 the disc optimum, 4 the full solves (docs/accuracy.md), 5 the rows of docs/benchmarks.md."""
    parts = [
        "Accuracy against run time (`PYTHONPATH=. python benchmarks/accuracy.py`); every row "
        "is in docs/figures/accuracy.json.", "", "References:", "",
        *reference_table(payload), "",
        "The paper's design (problems/sharkov2022.yaml), errors against the reference:", "",
        *evaluator_table(payload["paper"]["rows"]), "",
        "The disc problem's optimum (problems/sharkov2022_disc.yaml, default settings):", "",
        *evaluator_table(payload["optimum"]["rows"]), "",
        "Full solves of problems/sharkov2022_disc.yaml (δ error: against the best verified "
        "optimum of all settings):", "",
        *solve_table(payload["paper"]["rows"]), "",
        "The rows docs/benchmarks.md shows (the paper's design):", "",
        *readme_table(payload["paper"]["rows"])]
    return "\n".join(parts) + "\n"


def write_results(payload: dict) -> None:
    meta = {"python": platform.python_version(), "time": time.strftime("%Y-%m-%d %H:%M:%S"),
            "machine": f"{platform.machine()} {platform.system()}", "cores": os.cpu_count()}
    atomic_write_json(RESULTS / "accuracy.json", {"meta": meta, **payload})
    atomic_write_text(RESULTS / "accuracy.md", results_markdown(payload))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "docs" / "figures"))
    ap.add_argument("--no-crosscheck", action="store_true")
    args = ap.parse_args()
    out = Path(args.out)
    paper = load_problem(ROOT / "problems" / "sharkov2022.yaml")
    disc = load_problem(ROOT / "problems" / "sharkov2022_disc.yaml")
    cross = 0 if args.no_crosscheck else 2_000_000

    rows, ref = accuracy_rows(paper, crosscheck_samples=cross, solve_problem=disc)
    print(format_table(rows, ref))
    optimum = next(r for r in rows if r["method"] == "solve" and r["verified"])
    from optdesign.solver import solve
    best = solve(disc)           # the default settings' optimum: evaluate the evaluators there
    rows_opt, ref_opt = accuracy_rows(disc, values=best.design, crosscheck_samples=cross)
    print(f"\nat the optimum of {disc.name} (default settings, δ = {best.delta:.6f}):")
    print(format_table(rows_opt, ref_opt))

    payload = {"paper": {"reference": {"method": ref.method, **ref.figures.to_dict(),
                                       "crosscheck": ref.crosscheck}, "rows": rows},
               "optimum": {"design": best.design,
                           "reference": {"method": ref_opt.method, **ref_opt.figures.to_dict(),
                                         "crosscheck": ref_opt.crosscheck},
                           "rows": rows_opt},
               "first_verified_solve": optimum}
    atomic_write_json(out / "accuracy.json", payload)
    write_results(payload)
    import matplotlib.pyplot as plt
    for name, rs, title in (("accuracy.png", rows, "sharkov2022 design: δ error against run "
                             "time (full solves: sharkov2022_disc)"),
                            ("accuracy_optimum.png", rows_opt,
                             "sharkov2022_disc optimum: δ error against run time")):
        fig = plot_accuracy(rs, title=title)
        atomic_savefig(fig, out / name, dpi=120)
        plt.close(fig)
    print(f"wrote {out / 'accuracy.json'}, {out / 'accuracy.png'}, "
          f"{out / 'accuracy_optimum.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Error against run time of every evaluator: the table and figure of docs/accuracy.md.

Run from the repository root (a few minutes on 2 cores; the 2·10^6-sample cross-check alone
takes ~40 s):

    PYTHONPATH=. python benchmarks/accuracy.py [--out docs/figures] [--no-crosscheck]

Writes OUT/accuracy.png (the paper's design, problems/sharkov2022.yaml, plus full solves of
problems/sharkov2022_disc.yaml), OUT/accuracy_optimum.png (the same evaluators at the disc
problem's optimum) and OUT/accuracy.json (every row), and prints both tables.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from optdesign.accuracy import accuracy_rows, format_table, plot_accuracy  # noqa: E402
from optdesign.io import atomic_savefig, atomic_write_json  # noqa: E402
from optdesign.problem import load_problem  # noqa: E402


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
    from optdesign.solve import solve
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

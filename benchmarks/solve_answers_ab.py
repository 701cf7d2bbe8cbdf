"""The solve's answers at two commits, on the verdicts' oracle's problems: does a change of
the solver find better designs or worse ones, change a status, and at what cost in time?

The oracle's draws (``--problems``, ``--seed``, ``--mechanisms``: the same draws as
``benchmarks/solve_oracle.py``) are solved with the code of ``--base`` (a git worktree in a
temporary folder, given this tree's benchmark scripts) and with the working tree, both on the
very same problems: drawn once, by this tree's code, and handed to both (the oracle reads its
bounds off the screening's sampled values of the box, so a change of the screening would
otherwise move the problems' bounds in their last bits, and the answers of the few problems
that hang on a bound's last bit with them), in two processes at once (one per core). The answers are
compared on the problem's own objective (the exact key of each: lower is better; "better" is
the working tree's); per tree, the statuses, the `optimal` answers that rest on no converged
polish (a design where a polish stopped, or a screened one) and the time of all solves.

    python benchmarks/solve_answers_ab.py --base 84c47e9 [--problems 300] [--seed 0]
        [--mechanisms fourbar_converter slotted_lever pulse_reducer] [--resume] [--table-only]

Writes benchmarks/results/solve_answers_ab.md and .json (each tree's rows also in
``solve_answers_ab_<tree>.json`` as they come: ``--resume`` goes on from them); ``--name N``
writes ``N.md``, ``N.json`` and ``N_<tree>.json`` instead, so that a comparison the docs
quote keeps its file beside the others.
"""
from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from optdesign.lifetime import exit_on_sigterm  # noqa: E402

RESULTS = ROOT / "benchmarks" / "results"
TREES = ("base", "head")
MECHANISMS = ("fourbar_converter", "slotted_lever", "pulse_reducer")
#: this tree's scripts that the base tree runs (the draws and the rows, the same code)
SCRIPTS = ("oracle.py", "solve_perturbation.py", "solve_answers_ab.py")


def tree_rows(args) -> None:
    """Solve the draws of ``args`` with this process's tree (``ROOT``), rows to ``--_out``."""
    import oracle
    import optdesign
    from solve_perturbation import answer_rows

    print(f"{args._tree}: the code of {Path(optdesign.__file__).parent}", flush=True)
    draws = drawn(args)
    data = json.loads(Path(args._problems).read_text())
    answer_rows(args._tree, draws, Path(args._out),
                build=lambda draw: oracle.loaded(data[str(draw.seed)]))


def drawn(args) -> list:
    """The oracle's draws of ``args`` (its mechanisms only)."""
    import numpy as np

    import oracle

    rng = np.random.default_rng(args.seed)
    return [d for d in (oracle.random_draw(rng, i) for i in range(args.problems))
            if d.mechanism in args.mechanisms]


def problems_file(args, path: Path) -> None:
    """The problem data of every draw, made once by this tree's code, to ``path``: the
    oracle reads its bounds off the screening's sampled values, so a change of the
    screening would change the problems too, and both trees must solve the very same ones."""
    import oracle

    path.write_text(json.dumps({str(d.seed): oracle.build_data(d) for d in drawn(args)}))


def in_both_trees(base: Path, args, paths: dict, problems: Path) -> bool:
    """Each tree's solves (its own copy of this script), both at once; whether both ended
    well."""
    from solve_perturbation import solving_env

    env = solving_env()
    env.pop("PYTHONPATH", None)         # each tree's own code, from its own folder
    children = []
    try:
        for name, tree in (("base", base), ("head", ROOT)):
            children.append(subprocess.Popen(
                [sys.executable, str(tree / "benchmarks" / "solve_answers_ab.py"), "--_tree",
                 name, "--_out", str(paths[name]), "--_problems", str(problems),
                 "--problems", str(args.problems),
                 "--seed", str(args.seed), "--mechanisms", *args.mechanisms, "--base",
                 args.base], cwd=tree, env=env))
        return all([c.wait() == 0 for c in children])
    finally:        # interrupted: no tree's solves run on in a worktree about to be removed
        for child in children:
            if child.poll() is None:
                child.terminate()
                child.wait()


def tree_lines(rows: dict) -> list[str]:
    """Per tree: its statuses, the `optimal` answers on no converged polish, its time."""
    lines = ["| tree | problems | optimal | infeasible | failed | optimal on no converged "
             "polish | time of all solves [s] |", "|---|---|---|---|---|---|---|"]
    for name in TREES:
        mine = rows[name]
        count = {s: sum(1 for r in mine if r["status"] == s)
                 for s in ("optimal", "infeasible", "failed")}
        stopped = sum(1 for r in mine if r["status"] == "optimal" and r["converged"] == 0)
        lines.append(f"| {name} | {len(mine)} | {count['optimal']} | {count['infeasible']} | "
                     f"{count['failed']} | {stopped} | {sum(r['solve_s'] for r in mine):.0f} |")
    return lines


def table(rows: dict, summary: list[dict], moved: list[dict], base: str) -> str:
    from solve_perturbation import MOVED, moved_lines, summary_lines

    lines = [f"The solve's answers on the problems of the verdicts' oracle with the code of "
             f"{base} (base) and of the working tree (head), each tree in a process of its "
             f"own, both at once: an answer moved when its objective moved by more than "
             f"{MOVED:g} (relative); better or worse for head.", ""]
    lines += tree_lines(rows) + [""] + summary_lines(summary) + [""]
    lines += moved_lines(moved, "head", 30, first="base")
    same = same_to_the_bit(rows["base"], rows["head"])
    lines += ["", f"The same to the bit in both trees (status, the objective's exact key and "
                  f"the IPOPT iterations): {same} of {len(rows['base'])} answers."]
    return "\n".join(lines) + "\n"


def same_to_the_bit(base: list[dict], head: list[dict]) -> int:
    """How many answers the two trees give alike in status, exact key and iterations (the
    keys as JSON keeps them: every bit of a float)."""
    return sum(1 for a, b in zip(base, head, strict=True)
               if (a["status"], a["key"], a["iterations"]) ==
               (b["status"], b["key"], b["iterations"]))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--base", required=True, help="the commit to compare the working tree with")
    ap.add_argument("--problems", type=int, default=300)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--mechanisms", nargs="+", choices=MECHANISMS, default=list(MECHANISMS))
    ap.add_argument("--resume", action="store_true")
    ap.add_argument("--name", default="solve_answers_ab",
                    help="the results files' name (benchmarks/results/NAME.md, ...)")
    ap.add_argument("--_tree", choices=TREES, help=argparse.SUPPRESS)
    ap.add_argument("--_out", help=argparse.SUPPRESS)
    ap.add_argument("--_problems", help=argparse.SUPPRESS)
    ap.add_argument("--table-only", action="store_true",
                    help="write the tables again from the rows of the last run, solving nothing")
    args = ap.parse_args(argv)
    if not 1 <= args.problems <= 10_000:
        ap.error("--problems must be 1 to 10000")
    if args._tree:
        tree_rows(args)
        return 0
    if not re.fullmatch(r"[A-Za-z0-9_-]{1,64}", args.name):
        ap.error("--name must be 1 to 64 letters, digits, '_' or '-'")
    paths = {name: RESULTS / f"{args.name}_{name}.json" for name in TREES}
    if args.table_only:
        if not all(p.exists() for p in paths.values()):
            ap.error(f"no rows of a run named {args.name} to write the tables from")
        return _write(args, paths)
    if not args.resume:
        for path in paths.values():
            path.unlink(missing_ok=True)
    # a SIGTERM raises (exit_on_sigterm), so the worktree below is removed and the rows kept
    # so far let --resume go on
    with exit_on_sigterm(), tempfile.TemporaryDirectory(prefix="optdesign-answers-") as tmp:
        base = Path(tmp) / "base"
        subprocess.run(["git", "worktree", "add", "--detach", "-q", str(base), args.base],
                       cwd=ROOT, check=True)
        try:
            for script in SCRIPTS:
                shutil.copy2(ROOT / "benchmarks" / script, base / "benchmarks" / script)
            problems = Path(tmp) / "problems.json"
            problems_file(args, problems)
            ok = in_both_trees(base, args, paths, problems)
        finally:
            subprocess.run(["git", "worktree", "remove", "--force", str(base)], cwd=ROOT)
    if not ok:
        print("a tree's solves failed", file=sys.stderr)
        return 1
    return _write(args, paths)


def _write(args, paths: dict) -> int:
    """The comparison's tables and JSON from each tree's rows (``--table-only``: dated as the
    run that made them)."""
    from solve_perturbation import compare, write_results

    rows = {name: json.loads(p.read_text()) for name, p in paths.items()}
    summary, moved = compare(rows["base"], rows["head"])
    when = None
    if args.table_only and (RESULTS / f"{args.name}.json").exists():
        when = json.loads((RESULTS / f"{args.name}.json").read_text())["meta"]["time"]
    write_results(args.name,
                  {"base": args.base, "seed": args.seed, "problems": args.problems,
                   "mechanisms": args.mechanisms},
                  {"summary": summary, "moved": moved,
                   "same_to_the_bit": same_to_the_bit(rows["base"], rows["head"])},
                  table(rows, summary, moved, args.base), when)
    return 0


if __name__ == "__main__":
    sys.exit(main())

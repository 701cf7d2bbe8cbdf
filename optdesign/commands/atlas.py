"""``optdesign atlas ATLAS.yaml [--out DIR] [--workers W] [--scheduler ADDRESS] [--resume]
[--json] [--no-plots]``."""
from __future__ import annotations

import os

#: every file the command writes in its output folder
ATLAS_FILES = ("cells.jsonl", "atlas.csv", "atlas.json", "atlas_counts.png", "atlas_map.png",
               "atlas.html")


def add_parser(sub) -> None:
    from optdesign.commands.pareto import _positive
    from optdesign.limits import COUNTS, PROCESSES_PER_CORE
    p = sub.add_parser("atlas", help="least ripple over a grid of rules, in lengths relative "
                                     "to the crank (a design atlas)")
    p.add_argument("atlas", help="atlas file (YAML, docs/atlas.md)")
    p.add_argument("--out", help="output folder (default results/NAME/)")
    p.add_argument("--force", action="store_true",
                   help="replace results of another problem file in the output folder")
    p.add_argument("--workers", type=_positive(1, COUNTS["workers"]),
                   help="worker processes (default: every core; a local pool starts at most "
                        f"{PROCESSES_PER_CORE} per core)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run the cells on this Dask scheduler (needs optdesign[cluster])")
    p.add_argument("--resume", action="store_true",
                   help="continue an interrupted atlas in --out without solving its cells again")
    p.add_argument("--json", action="store_true", help="print atlas.json")
    p.add_argument("--no-plots", action="store_true", help="atlas.csv/json only")
    p.set_defaults(run=run)


def run(args) -> int:
    from optdesign.atlas.run import JOURNAL, run_atlas
    from optdesign.atlas.spec import load_atlas
    from optdesign.atlas.table import document, write_table
    from optdesign.commands.pareto import _connected
    from optdesign.errors import ProblemError
    from optdesign.figures.design import warm_up
    from optdesign.lifetime import exit_on_sigterm
    from optdesign.outputs.atomic import json_text
    from optdesign.outputs.checks import prepare_out, resolve_out
    from optdesign.outputs.figure_process import FigureProcess
    from optdesign.outputs.folder import OutputFolder

    spec = load_atlas(args.atlas)
    out, _ = resolve_out(args.out, spec.name)
    if args.resume and not os.path.lexists(out / JOURNAL):
        raise ProblemError(f"{out / JOURNAL}: nothing to resume (no journal there)")
    # a resumed atlas's journal checks whose it is itself
    out = prepare_out(args.out, spec.name, files=ATLAS_FILES,
                      source=None if args.resume else args.atlas, force=args.force,
                      record=False)
    # the charts are drawn beside, by a process forked before any thread or worker (a Dask
    # client, the cells' pool) exists: it imports matplotlib while the cells are solved, and
    # draws both charts at once while this process writes the table and the page
    with FigureProcess(enabled=not args.no_plots, warm=warm_up) as figures, \
            _connected(args.scheduler) as scheduler, exit_on_sigterm(), \
            OutputFolder(out, ATLAS_FILES, args.atlas) as folder:
        if not args.resume:
            folder.remove_owned()
        result = run_atlas(spec, out, workers=args.workers, resume=args.resume,
                           scheduler=scheduler, progress=not args.json)
        if not args.no_plots:
            from optdesign.atlas.charts import chart_jobs
            from optdesign.atlas.page import write_page
            figures.draw(chart_jobs(result, out))
        files = write_table(result, out)
        if not args.no_plots:
            page = write_page(result, out)
            files += figures.wait() + [page]
    failed = [r for r in result.records if r["status"] not in ("optimal", "infeasible")]
    if args.json:
        print(json_text(document(result)))
    else:
        print(f"{spec.name}: {len(result.records)} cells, {result.n_feasible} feasible, "
              f"{len(failed)} failed ({result.run['resumed_cells']} resumed) in "
              f"{result.run['wall_time_s']:.1f} s")
        print(f"wrote {', '.join(str(f) for f in files)}")
    return 1 if failed else 0

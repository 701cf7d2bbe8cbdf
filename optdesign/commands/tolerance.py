"""``optdesign tolerance PROBLEM.yaml [--out DIR] [--samples N] [--seed S] [--json]
[--design FILE [--point K | --knee]]``: will the design still be smooth when its parts are made to
tolerance?

Needs a ``tolerances:`` section (:mod:`optdesign.tolerance.section`). Writes
DIR/tolerance.json, DIR/tolerance.csv (one row per Monte Carlo part) and the histograms
DIR/tolerance.png, the three replacing an earlier run's whole; default DIR is results/NAME/.
Exit 0 when the analysis ran (parts that fail are reported, not an error); 1 when the nominal
design itself does not assemble; 2 for bad input.
"""
from __future__ import annotations

import sys

from optdesign.commands.design_source import add_arguments, chosen_design
from optdesign.limits import COUNTS
from optdesign.outputs.phases import phase

#: most parts of --samples (tolerances.samples has the same limit)
MAX_SAMPLES = COUNTS["parts"]
MAX_SEED = 2**32 - 1


def add_parser(sub) -> None:
    p = sub.add_parser("tolerance", help="Monte Carlo parts and the worst case over the "
                                         "tolerance box of a design (needs a tolerances: "
                                         "section)")
    p.add_argument("problem", help="problem file (YAML) with a tolerances: section")
    p.add_argument("-o", "--out", help="output directory (default results/NAME/)")
    p.add_argument("--force", action="store_true",
                   help="replace results of another problem file in the output folder")
    p.add_argument("--samples", type=int, help="Monte Carlo parts (default tolerances.samples)")
    p.add_argument("--seed", type=int, help="seed of the sample (default tolerances.seed)")
    add_arguments(p)
    p.add_argument("--json", action="store_true", help="print tolerance.json")
    p.set_defaults(run=run)


def run(args) -> int:
    with phase("imports"):
        from optdesign.errors import UsageError
        from optdesign.figures.design import warm_up
        from optdesign.outputs.answer import print_answer, raise_if_unprinted
        from optdesign.outputs.atomic import json_text
        from optdesign.outputs.checks import prepare_out
        from optdesign.outputs.figure_process import FigureProcess
        from optdesign.outputs.folder import write_set
        from optdesign.commands.files import TOLERANCE_FILES, draw_tolerance, write_tolerance
        from optdesign.problem.loader import load_problem
        from optdesign.tolerance.parts import box_of

    with phase("reading"):
        problem = load_problem(args.problem)
    if "tolerances" not in problem.sections:
        raise UsageError(f"{problem.source}: has no tolerances: section; add one, e.g. "
                         f"tolerances: {{default: 0.05}} (± mm of every length; "
                         f"docs/tolerance.md)")
    section = problem.sections["tolerances"]
    if args.samples is not None and not 1 <= args.samples <= MAX_SAMPLES:
        raise UsageError(f"--samples must lie in [1, {MAX_SAMPLES}] (got {args.samples})")
    if args.seed is not None and not 0 <= args.seed <= MAX_SEED:
        raise UsageError(f"--seed must lie in [0, {MAX_SEED}] (got {args.seed})")
    with phase("reading"):
        chosen = chosen_design(args, problem)
    values, source = chosen.values, chosen.source
    box = box_of(problem, values, section)
    out = prepare_out(args.out, problem.name, files=TOLERANCE_FILES, source=args.problem,
                      force=args.force)      # before any work
    # the figures' process imports matplotlib while this one samples the parts
    with FigureProcess(warm=warm_up) as figures:
        with phase("imports"):
            import scipy.optimize  # noqa: F401  (brentq, first used by the evaluation)
            from tqdm import tqdm

            from optdesign.tolerance.montecarlo import monte_carlo
            from optdesign.tolerance.report import format_tolerance, tolerance_document
            from optdesign.tolerance.worst_case import worst_case
        with phase("evaluating"):
            with tqdm(total=3, desc="tolerance", unit="stage", file=sys.stderr,
                      disable=None, leave=False) as bar:
                frame = monte_carlo(problem, box.values, section, args.samples, args.seed)
                if not frame.attrs["nominal"]["assembles"]:
                    print(f"optdesign: {problem.source}: the nominal design does not "
                          f"assemble; nothing to analyse", file=sys.stderr)
                    return 1
                bar.update()
                worst = frame[frame["assembles"]].nlargest(8, "delta")
                offsets = worst[[f"{k}_offset_mm" for k in box.names]].to_numpy()
                worst_delta = worst_case(problem, box.values, section, candidates=offsets)
                bar.update()
                least = frame[frame["assembles"]].nsmallest(8, "mu_min_deg")
                offsets = least[[f"{k}_offset_mm" for k in box.names]].to_numpy()
                worst_angle = worst_case(problem, box.values, section,
                                         quantity="transmission_angle", candidates=offsets)
                bar.update()
            doc = tolerance_document(problem, box, section, frame, worst_delta, worst_angle,
                                     source)

        def write(into):
            with phase("files"):
                written = write_tolerance(doc, frame, into, plots=False)
                print_answer(json_text(doc) if args.json else format_tolerance(doc))
            with phase("figures"):
                return written + draw_tolerance(doc, frame, into, figures)
        files = write_set(out, TOLERANCE_FILES, write)      # the earlier set, or this one
    raise_if_unprinted()
    if not args.json:
        print(f"wrote {', '.join(str(f) for f in files)}")
    return 0

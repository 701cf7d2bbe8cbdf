"""``optdesign tolerance PROBLEM.yaml [--out DIR] [--samples N] [--seed S] [--json]
[--design RESULT.json]``: will the design still be smooth when its parts are made to
tolerance?

Needs a ``tolerances:`` section (:mod:`optdesign.tolerance.section`). Writes
DIR/tolerance.json, DIR/tolerance.csv (one row per Monte Carlo part) and the histograms
DIR/tolerance.png, each atomically; default DIR is results/NAME/. Exit 0 when the analysis
ran (parts that fail are reported, not an error); 1 when the nominal design itself does not
assemble; 2 for bad input.
"""
from __future__ import annotations

import sys

#: most parts of --samples (tolerances.samples has the same limit)
MAX_SAMPLES = 10_000_000
MAX_SEED = 2**32 - 1


def add_parser(sub) -> None:
    p = sub.add_parser("tolerance", help="Monte Carlo parts and the worst case over the "
                                         "tolerance box of a design (needs a tolerances: "
                                         "section)")
    p.add_argument("problem", help="problem file (YAML) with a tolerances: section")
    p.add_argument("-o", "--out", help="output directory (default results/NAME/)")
    p.add_argument("--samples", type=int, help="Monte Carlo parts (default tolerances.samples)")
    p.add_argument("--seed", type=int, help="seed of the sample (default tolerances.seed)")
    p.add_argument("--design", metavar="RESULT.json",
                   help="analyse this design (a solve's result.json, or any JSON with a "
                        "design object) instead of the file's fixed and initial values")
    p.add_argument("--json", action="store_true", help="print tolerance.json")
    p.set_defaults(run=run)


def run(args) -> int:
    from optdesign.errors import UsageError
    from optdesign.outputs.atomic import json_text
    from optdesign.outputs.checks import prepare_out
    from optdesign.commands.files import TOLERANCE_FILES, write_tolerance
    from optdesign.problem.loader import load_problem
    from optdesign.tolerance.montecarlo import monte_carlo
    from optdesign.tolerance.parts import box_of
    from optdesign.tolerance.report import format_tolerance, tolerance_document
    from optdesign.tolerance.worst_case import worst_case

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
    if args.design is not None:
        values = read_design(args.design, problem)
        source = f"the design of {args.design}"
    else:
        values = None
        count = problem.model.count_variable
        if len(problem.counts()) > 1:
            raise UsageError(f"{problem.source}: design.{count} is free; give a solved design "
                             f"with --design RESULT.json")
        source = ("the file's initial design (free lengths at their initial values; "
                  "--design RESULT.json analyses a solved one)" if problem.free_lengths()
                  else "the file's design")
    box = box_of(problem, values, section)
    out = prepare_out(args.out, problem.name, files=TOLERANCE_FILES)      # before any work
    from tqdm import tqdm
    with tqdm(total=3, desc="tolerance", unit="stage", file=sys.stderr, disable=None,
              leave=False) as bar:
        frame = monte_carlo(problem, box.values, section, args.samples, args.seed)
        if not frame.attrs["nominal"]["assembles"]:
            print(f"optdesign: {problem.source}: the nominal design does not assemble; "
                  f"nothing to analyse", file=sys.stderr)
            return 1
        bar.update()
        worst = frame[frame["assembles"]].nlargest(8, "delta")
        offsets = worst[[f"{k}_offset_mm" for k in box.names]].to_numpy()
        worst_delta = worst_case(problem, box.values, section, candidates=offsets)
        bar.update()
        least = frame[frame["assembles"]].nsmallest(8, "mu_min_deg")
        offsets = least[[f"{k}_offset_mm" for k in box.names]].to_numpy()
        worst_angle = worst_case(problem, box.values, section, quantity="transmission_angle",
                                 candidates=offsets)
        bar.update()
    doc = tolerance_document(problem, box, section, frame, worst_delta, worst_angle, source)
    files = write_tolerance(doc, frame, out)
    if args.json:
        print(json_text(doc))
    else:
        print(format_tolerance(doc))
        print(f"wrote {', '.join(str(f) for f in files)}")
    return 0


def read_design(path: str, problem) -> dict:
    """The ``design`` object of a JSON file (a solve's result.json), checked against the
    problem: every key a design key of its mechanism, every value a positive number. Any
    fault is a UsageError naming the file."""
    import json
    import math
    from pathlib import Path

    from optdesign.errors import ProblemError, UsageError, shown
    from optdesign.problem.yaml_text import read_text

    try:                        # a regular file of at most 1 MiB (never /dev/zero or a FIFO)
        text = read_text(Path(path))
    except ProblemError as exc:
        reason = str(exc).split(": ", 1)[-1]
        raise UsageError(f"--design {shown(path)}: {reason}") from None
    try:
        data = json.loads(text)
    except (ValueError, RecursionError):
        raise UsageError(f"--design {shown(path)}: is not JSON") from None
    design = data.get("design") if isinstance(data, dict) else None
    if not isinstance(design, dict):
        raise UsageError(f"--design {shown(path)}: has no design object (a solve that found "
                         f"none writes design: null)")
    if isinstance(data.get("mechanism"), str) and data["mechanism"] != problem.mechanism:
        raise UsageError(f"--design {shown(path)}: is a design of {shown(data['mechanism'])}, "
                         f"the problem's mechanism is {problem.mechanism}")
    values = {}
    for key, value in design.items():
        if key not in problem.design:
            name = key if isinstance(key, str) and key.isprintable() and len(key) <= 40 \
                else shown(key, 40)
            raise UsageError(f"--design {shown(path)}: design.{name} is not a design key of "
                             f"{problem.mechanism}")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or \
                not math.isfinite(value) or value <= 0:
            raise UsageError(f"--design {shown(path)}: design.{key} must be a positive number "
                             f"(got {shown(value)})")
        values[key] = float(value)
    count = problem.model.count_variable
    if count not in values and len(problem.counts()) > 1:
        raise UsageError(f"--design {shown(path)}: design.{count} is missing")
    if count in values:
        admissible = problem.counts()
        if values[count] != int(values[count]) or int(values[count]) not in admissible:
            span = f"{admissible[0]}–{admissible[-1]}" if len(admissible) > 1 else \
                str(admissible[0])
            raise UsageError(f"--design {shown(path)}: design.{count} must be a whole number "
                             f"the problem admits ({span}; got {shown(design[count])})")
        values[count] = int(values[count])
    return values

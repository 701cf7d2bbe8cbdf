"""``optdesign compare A B [C ...] [--problem P.yaml] [--json] [--out DIR]``: candidate designs
side by side.

Each of A, B, ... is a ``design.yaml`` (a problem file, its design fixed) or a solve's
``result.json`` (evaluated as the ``design.yaml`` beside it, else under ``--problem``, else
under the problem its own keys describe, the mechanism's options at their defaults). Prints a table: lengths, count, δ, ratio, least
transmission angle, every quantity, the robust solve's worst δ where present; writes
``compare.csv`` and ``compare.png`` (their output speeds overlaid) into DIR (default
results/compare/). Exit 0; 2 for bad input (one line naming the file).
"""
from __future__ import annotations

#: most designs compared at once
MAX_DESIGNS = 12


def add_parser(sub) -> None:
    p = sub.add_parser("compare", help="candidate designs side by side: a table and their "
                                       "output speeds overlaid")
    p.add_argument("designs", nargs="+", metavar="DESIGN",
                   help="a design.yaml, or a solve's result.json (two or more)")
    p.add_argument("--problem", help="evaluate result.json designs under this problem file")
    p.add_argument("--json", action="store_true", help="print the table as JSON")
    p.add_argument("--out", help="output directory (default results/compare/)")
    p.set_defaults(run=run)


def run(args) -> int:
    from optdesign.analyses.compare import compare, envelopes
    from optdesign.commands.files import save_figure
    from optdesign.errors import UsageError
    from optdesign.figures.design import plot_envelopes
    from optdesign.outputs.atomic import atomic_write_text, json_text
    from optdesign.outputs.checks import prepare_out
    from optdesign.outputs.folder import write_set
    from optdesign.outputs.units import stamped
    from optdesign.problem.loader import load_problem

    if not 2 <= len(args.designs) <= MAX_DESIGNS:
        raise UsageError(f"compare takes 2 to {MAX_DESIGNS} designs (got {len(args.designs)})")
    base = load_problem(args.problem) if args.problem else None
    candidates = [candidate(path, base) for path in args.designs]
    out = prepare_out(args.out, "compare", files=("compare.csv", "compare.png"))
    rows = compare(candidates)
    import pandas as pd

    table = pd.DataFrame(rows)
    named = {r["label"]: r for r in rows if r.get("delta_label")}
    at = {label: r["delta_eccentricity"] for label, r in named.items()}
    curves = {(f"{label}: {named[label]['delta_label']} = {named[label]['delta']:.6f}"
               if label in named else label): curve
              for label, curve in envelopes(candidates, eccentricities=at).items()}

    def write(into):
        return [atomic_write_text(into / "compare.csv",
                                  table.to_csv(index=False, float_format="%.10g")),
                save_figure(plot_envelopes(curves, title="output speed over one crank turn, "
                                                         "each at the eccentricity of its δ"),
                            into / "compare.png")]
    write_set(out, ("compare.csv", "compare.png"), write)
    if args.json:
        print(json_text(stamped({"designs": rows}, _units(candidates))))
    else:
        shown = table.set_index("label").T
        print(shown.to_string(float_format=lambda v: f"{v:.6g}"))
        print(f"wrote {out / 'compare.csv'}, {out / 'compare.png'}")
    return 0


def candidate(path: str, base=None):
    """The :class:`~optdesign.analyses.compare.Candidate` a command-line argument names."""
    from pathlib import Path

    from optdesign.analyses.compare import Candidate
    from optdesign.commands.design_source import design_from_file, read_json
    from optdesign.errors import UsageError, shown
    from optdesign.problem.loader import load_problem, problem_from_dict

    file = Path(path)
    if file.suffix.lower() in (".yaml", ".yml"):
        return Candidate(path, load_problem(file))
    if file.suffix.lower() != ".json":
        raise UsageError(f"{shown(path)}: compare takes a design.yaml or a result.json")
    beside = file.with_name("design.yaml")
    problem = base or (load_problem(beside) if beside.is_file() else None)
    data = read_json(file, shown(path))
    if not isinstance(data, dict):
        raise UsageError(f"{shown(path)}: has no design object")
    if problem is None:             # the problem its own keys describe
        objective = data.get("objective") if isinstance(data.get("objective"), dict) else {}
        problem = problem_from_dict({
            "name": data.get("name", file.stem), "mechanism": data.get("mechanism"),
            "input_speed": data.get("input_speed"), "stroke": data.get("stroke", "forward"),
            "design": data.get("design"),
            "objective": {"ripple": objective.get("ripple", "midrange")},
            "regulation": {"eccentricity": objective.get("eccentricities", [1.0])}},
            where=str(file.name))
    chosen = design_from_file(path, problem)
    extra = {}
    if isinstance(data.get("worst_case_delta"), (int, float)):
        extra["worst_case_delta"] = float(data["worst_case_delta"])
    return Candidate(path, chosen.problem(problem), extra)


def _units(candidates) -> dict:
    from optdesign.quantities import get_quantity, known

    lengths = {k for c in candidates for k in c.problem.model.lengths}
    return {k: "mm" for k in lengths} | {
        "count": "- (count)", "delta": "-", "ratio": "-", "min_transmission_angle_deg": "deg",
        "worst_case_delta": "-"} | {n: get_quantity(n).unit for n in known()}

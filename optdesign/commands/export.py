"""``optdesign export PROBLEM.yaml [--design FILE [--point K | --knee]] [--format dxf,svg,csv]
[--angle DEG] [--eccentricity E] [--out DIR]``: a design out to CAD and spreadsheets.

Writes ``linkage.dxf`` (the linkage to scale in mm at the crank angle, layers by role, a title
block; :mod:`optdesign.export.drawing`), ``linkage.svg`` (the same drawing) and
``trajectories.csv`` (every joint's path and every output member's θ, ω, ε over a turn), each
atomically, into DIR (default results/NAME/). Exit 0; 1 when the design does not assemble at
the eccentricity; 2 for bad input.
"""
from __future__ import annotations

from optdesign.commands.design_source import add_arguments, checked_eccentricity, loaded
from optdesign.outputs.phases import answered, phase

FORMATS = {"dxf": "linkage.dxf", "svg": "linkage.svg", "csv": "trajectories.csv"}


def add_parser(sub) -> None:
    p = sub.add_parser("export", help="the linkage to scale as DXF and SVG, and its joints' "
                                      "trajectories as CSV")
    p.add_argument("problem", help="problem file (YAML)")
    add_arguments(p)
    p.add_argument("--format", default="dxf,svg,csv",
                   help="what to write, comma-separated: dxf, svg, csv (default all)")
    p.add_argument("--angle", type=float, default=0.0,
                   help="crank angle of the drawing, degrees (default 0)")
    p.add_argument("--eccentricity", type=float, default=1.0,
                   help="fraction e of the regulating length (default 1)")
    p.add_argument("--out", help="output directory (default results/NAME/)")
    p.add_argument("--force", action="store_true",
                   help="replace results of another problem file in the output folder")
    p.set_defaults(run=run)


def run(args) -> int:
    with phase("imports"):
        import math

        import scipy.optimize  # noqa: F401  (brentq, first used by the evaluation)

        from optdesign.analyses.analyze import analyze
        from optdesign.errors import UsageError
        from optdesign.evaluation.design import Design
        from optdesign.outputs.checks import prepare_out
        from optdesign.outputs.folder import write_set
        from optdesign.problem.loader import load_problem  # noqa: F401  (read by loaded())

    with phase("reading"):
        problem, chosen = loaded(args)
    checked_eccentricity(args.eccentricity)
    formats = [f.strip().lower() for f in args.format.split(",") if f.strip()]
    unknown = [f for f in formats if f not in FORMATS]
    if unknown or not formats:
        raise UsageError(f"--format takes dxf, svg and csv, comma-separated (got "
                         f"{args.format!r})")
    if not math.isfinite(args.angle):
        raise UsageError(f"--angle must be a number of degrees (got {args.angle})")
    out = prepare_out(args.out, problem.name, files=tuple(FORMATS[f] for f in formats),
                      source=args.problem, force=args.force)
    with phase("evaluating"):
        design = Design.from_problem(problem)
        design.check_assembly(args.eccentricity)      # AssemblyError: exit 1, names the chain
        result = analyze(problem)
    owned = tuple(FORMATS[f] for f in formats)
    written = write_set(out, owned, lambda into: _write(problem, design, result, args,
                                                         formats, into))
    answered()
    print(chosen.line(problem))
    print(f"wrote {', '.join(str(p) for p in written)}")
    return 0


def _write(problem, design, result, args, formats, out) -> list:
    """The files of ``formats``, into the folder ``out``."""
    import io

    from optdesign.outputs.atomic import atomic_write_text

    written = []
    with phase("files"):
        if "dxf" in formats or "svg" in formats:
            from optdesign.export.drawing import linkage_document

            doc = linkage_document(design, _title(problem, design, result, args), args.angle,
                                   args.eccentricity)
            if "dxf" in formats:
                stream = io.StringIO()
                doc.write(stream)
                written.append(atomic_write_text(out / FORMATS["dxf"], stream.getvalue()))
            if "svg" in formats:
                from optdesign.export.svg import svg_text

                written.append(atomic_write_text(out / FORMATS["svg"], svg_text(doc)))
        if "csv" in formats:
            from optdesign.export.trajectories import trajectories

            table = trajectories(design, problem.stroke, problem.input_speed,
                                 args.eccentricity)
            written.append(atomic_write_text(out / FORMATS["csv"],
                                             table.to_csv(index=False, float_format="%.12g")))
    return written


def _title(problem, design, result, args) -> dict:
    """The title block: what the drawing is of, each length (mm) and the exact figures, δ
    named (:mod:`optdesign.evaluation.ripples`): the problem's, then at each eccentricity."""
    from optdesign.analyses.analyze import ripples_of_analysis
    from optdesign.evaluation.ripples import ripple_label

    model = problem.model
    stroke = result.strokes[problem.stroke]
    title = {"name": problem.name, "mechanism": problem.mechanism,
             model.count_variable: design.count,
             "eccentricity": float(args.eccentricity), "crank angle (deg)": float(args.angle)}
    title |= {f"{k} (mm)": float(design.values[k]) for k in model.lengths}
    named = ripples_of_analysis(problem, result)
    if named is None:
        title |= {ripple_label(problem.objective.ripple, 1.0): float(stroke.delta)}
    else:
        title |= {named.worst.label: named.worst.value}
        title |= {r.label: r.value for r in named.each if len(named.each) > 1}
    title |= {"ratio": float(stroke.ratio)}
    if result.min_transmission_angle_deg is not None:
        title["least transmission angle (deg)"] = float(result.min_transmission_angle_deg)
    return title

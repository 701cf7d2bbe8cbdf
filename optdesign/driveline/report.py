"""What ``optdesign driveline`` prints: the shaft's figures, its margins and the check's verdict.

:func:`driveline_report` gathers them into one flat dict (the keys of ``analyze``'s
``driveline`` object, plus ``name``, ``mechanism``, ``stroke``, ``verdict`` and ``figure``),
printed by ``--json``; :func:`format_driveline` turns it into the terminal's text.
"""
from __future__ import annotations

from optdesign.driveline.section import CONSTRAINT_KEY
from optdesign.outputs.units import stamped

#: ``verdict`` of the speed check: the constraint ``max_speed_fraction_of_critical`` holds or
#: not; ``unchecked`` when the file sets no constraint; ``no_output_speed`` when the design does
#: not assemble and the file fixes no operating speed
VERDICTS = ("holds", "violated", "unchecked", "no_output_speed")


def driveline_report(problem, analysis, figure: str | None = None) -> dict:
    """The ``driveline --json`` object of ``problem`` (with a ``driveline:`` section) and its
    :class:`~optdesign.analyses.analyze.AnalysisResult`; ``figure`` the path of the figure written;
    ``schema_version`` and ``units`` at the end."""
    section = problem.sections["driveline"]
    figures = analysis.sections.get("driveline") or section.analyze(problem, analysis)
    if figures.get("operating_speed_rad_s") is None:
        verdict = "no_output_speed"
    elif "speed_constraint_holds" not in figures:
        verdict = "unchecked"
    else:
        verdict = "holds" if figures["speed_constraint_holds"] else "violated"
    out = {"name": problem.name, "mechanism": problem.mechanism, "stroke": problem.stroke,
           "assembles": analysis.assembles, "verdict": verdict, **figures}
    if not analysis.assembles:
        out["failure"] = analysis.failure
    if figure is not None:
        out["figure"] = figure
    return stamped(out)


def format_driveline(report: dict) -> str:
    """The report as lines for the terminal: lengths in mm, speeds in rad/s (and rpm)."""
    r = report
    rpm = 30.0 / 3.141592653589793
    lines = [
        f"{r['name']}: cardan shaft after the {r['mechanism']} ({r['stroke']} stroke)",
        f"  shaft            length {r['length_mm']:.6g} mm between supports, correction "
        f"planes A = {r['A_mm']:.6g} mm, C = {r['C_mm']:.6g} mm",
        f"                   mass {r['mass_kg']:.4g} kg ({r['mass_per_length_kg_m']:.4g} kg/m), "
        f"EI = {r['EI_n_m2']:.4g} N·m²",
        f"                   initial bend y0_max = {r['y0_max_mm']:.4g} mm "
        f"({r['y0_max_source']})",
        f"  critical speed   ω_cr = {r['critical_speed_rad_s']:.6g} rad/s "
        f"({r['critical_speed_rpm']:.6g} rpm)",
    ]
    omega = r.get("operating_speed_rad_s")
    if omega is None:
        lines.append(f"  operating speed  none: the design does not assemble "
                     f"({(r.get('failure') or {}).get('message', '')})")
    else:
        lines += [
            f"  operating speed  {omega:.6g} rad/s ({omega * rpm:.6g} rpm; "
            f"{r['operating_speed_source']}), {r['speed_fraction_of_critical']:.4g} of ω_cr",
            f"  bend             y_max = {r['y_max_mm']:.4g} mm (amplification "
            f"{r['amplification']:.6g}); balanced at this speed {r['y_max_balanced_mm']:.4g} mm",
            f"  imbalance        D0 = {r['D0_g_mm']:.4g} g·mm; corrections Dk1 = "
            f"{r['Dk1_g_mm']:.4g}, Dk2 = {r['Dk2_g_mm']:.4g} g·mm",
            f"                   balanced at {r['balancing_speed_rad_s']:.4g} rad/s instead: "
            f"residual {r['low_speed_residual1_g_mm']:.4g}, "
            f"{r['low_speed_residual2_g_mm']:.4g} g·mm per plane",
        ]
        if "speed_limit_rad_s" in r:
            lines.append(f"  speed limit      {r['speed_limit_rad_s']:.6g} rad/s "
                         f"({CONSTRAINT_KEY} = {r[CONSTRAINT_KEY]:g})")
        margin = f"  margin           {r['critical_margin_rad_s']:.6g} rad/s below ω_cr"
        if "speed_margin_rad_s" in r:
            side = "below" if r["speed_margin_rad_s"] >= 0 else "ABOVE"
            margin += f"; {abs(r['speed_margin_rad_s']):.6g} rad/s {side} the limit"
        lines.append(margin)
    limit = r.get(CONSTRAINT_KEY)
    lines.append("  check            " + {
        "holds": f"holds: the shaft turns at {r.get('speed_fraction_of_critical', 0):.4g} of "
                 f"ω_cr, at most {CONSTRAINT_KEY} = {limit}",
        "violated": f"VIOLATED: the shaft turns at {r.get('speed_fraction_of_critical', 0):.4g}"
                    f" of ω_cr, above {CONSTRAINT_KEY} = {limit}",
        "unchecked": f"not checked (the file sets no constraints.{CONSTRAINT_KEY})",
        "no_output_speed": "not made: no operating speed",
    }[r["verdict"]])
    return "\n".join(lines)

"""What the explorer shows of one design: the exact evaluator's figures and its turn.

Every slider move evaluates the design exactly, as ``optdesign analyze`` does
(:func:`optdesign.analyses.analyze.analyze`: δ named as ``solve`` names it, the ratio, the
least transmission angle, every quantity and every constraint's margin; the speed figures of
the problem's stroke alone, the only stroke the page shows), and samples its
turn at the drawn eccentricity (:func:`optdesign.export.animation.turn`: the joints, each
rocker's speed, and the output speed at each listed eccentricity, labelled with its δ), as
``optdesign animate`` draws it. Nothing is estimated from a sample.
"""
from __future__ import annotations

from dataclasses import dataclass

from optdesign.errors import AssemblyError, ProblemError

#: crank angles of one turn drawn (and played)
FRAMES = 120


@dataclass(frozen=True)
class Row:
    """One line of the figures table: a name, its value as text, and whether it breaks a
    constraint (shown red)."""

    name: str
    value: str
    violated: bool = False


@dataclass(frozen=True)
class Snapshot:
    """A design evaluated: ``analysis`` (None when it could not be evaluated), its
    :class:`~optdesign.export.animation.Turn` at the drawn ``eccentricity`` (None when it
    does not assemble there), and ``message``: one line when something is wrong (the chain
    and crank angle where it does not assemble), else empty."""

    values: dict
    eccentricity: float
    analysis: object | None
    turn: object | None
    message: str = ""

    @property
    def assembles(self) -> bool:
        return self.analysis is not None and self.analysis.assembles and self.turn is not None

    @property
    def ripples(self):
        """The design's δ named (:class:`optdesign.evaluation.ripples.Ripples`), or None."""
        return self.analysis.ripples() if self.analysis is not None else None

    @property
    def delta_text(self) -> str:
        """``δ (midrange, worst over e = 1) = 0.376413``, as ``solve`` writes it."""
        named = self.ripples
        return named.worst.text(6) if named is not None else "δ: not evaluated"

    @property
    def ratio(self) -> float | None:
        if self.analysis is None or not self.analysis.assembles:
            return None
        return self.analysis.quantities.get("values", {}).get("ratio")

    def rows(self) -> list[Row]:
        """The figures table: δ at each listed eccentricity, the ratio, the least
        transmission angle, every quantity, then every constraint with its margin."""
        a = self.analysis
        if a is None or not a.assembles:
            return []
        out = [Row(r.label, f"{r.value:.6f}") for r in self.ripples.each] \
            if self.ripples is not None else []
        from optdesign.quantities import get_quantity

        for name, value in a.quantities.get("values", {}).items():
            unit = get_quantity(name).unit
            text = f"{value:.6g}" + ("" if unit in ("", "-") else f" {unit}")
            out.append(Row(name, text))
        for c in a.constraints:
            unit = "" if c.get("unit") in (None, "", "-") else f" {c['unit']}"
            state = "met" if c["satisfied"] else "VIOLATED"
            out.append(Row(f"margin of {c['name']}", f"{c['margin']:+.4g}{unit} ({state})",
                           violated=not c["satisfied"]))
        return out


def snapshot(problem, values: dict, eccentricity: float = 1.0,
             frames: int = FRAMES) -> Snapshot:
    """The :class:`Snapshot` of ``values`` (every design key) under ``problem``, drawn at
    ``eccentricity``."""
    from optdesign.analyses.analyze import analyze
    from optdesign.evaluation.design import Design
    from optdesign.export.animation import turn

    try:
        result = analyze(problem, values, every_stroke=False)    # the page shows one stroke
    except ProblemError as exc:          # values the mechanism refuses (l1 >= l0)
        return Snapshot(dict(values), eccentricity, None, None, _plain(exc))
    if not result.assembles:
        return Snapshot(dict(values), eccentricity, result, None, result.failure["message"])
    design = Design.from_problem(problem, values)
    if eccentricity not in {1.0, *problem.eccentricities}:     # not evaluated already
        try:
            design.check_assembly(eccentricity)
        except AssemblyError as exc:
            return Snapshot(dict(values), eccentricity, result, None, str(exc))
    named = result.ripples()
    labels = tuple((r.at, r.text(4)) for r in named.each if r.at is not None) \
        if named is not None else ()
    drawn = turn(design, problem.stroke, problem.input_speed, eccentricity, frames,
                 outputs=labels)
    return Snapshot(dict(values), eccentricity, result, drawn, "")


def _plain(exc: Exception) -> str:
    """A loader's message without the file name in front (the page names the file)."""
    text = str(exc)
    return text.split(": ", 1)[-1] if text.startswith(("/", "<", ".")) or ".yaml" in \
        text.split(": ", 1)[0] else text

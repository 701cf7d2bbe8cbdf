"""The ``pareto:`` section of a problem file: how ``optdesign pareto`` sweeps the front.

Registered in ``optdesign.problem.loader.SECTION_PARSERS``; every key is optional::

    pareto:
      points: 12            # ε values per phase count, end points included (default 12)
      against: ratio        # the quantity traded against the ripple (or housing_radius ...)
      ratio_lower: 0.5      # sweep ε from here ... (default: the least-ripple design's ratio)
      ratio_upper: 0.8      # ... to here (default: the largest ratio the linkage reaches)
      counts: [4, 6]        # phase counts to sweep (default: every admissible count)
      refine:               # after the uniform pass, more ε where the front is coarse
        enabled: true
        max_gap: 0.1        # normalised (ratio, δ) distance between neighbours
        max_points: 12      # most refined points per phase count
        max_turn_deg: 30    # a turn of the slope dδ/d ratio between neighbours
        hypervolume_gap: 3.0e-5   # then over every count: hypervolume a gap may leave
        hypervolume_points: 100   # most points those rounds add in all

The ε range is always clipped to what each phase count can reach, so a span wider than the
achievable range is harmless; a span that misses it leaves that count with no sweep points.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

from optdesign.declarations import Key, names
from optdesign.limits import COUNTS
from optdesign.fronts.axis import choices as axis_choices
from optdesign.fronts.refine import (DEFAULT_DELTA_RESOLUTION, DEFAULT_HYPERVOLUME_GAP,
                                     DEFAULT_HYPERVOLUME_POINTS, DEFAULT_MAX_GAP,
                                     DEFAULT_MAX_POINTS, DEFAULT_MAX_TURN_DEG, GAIN_RESOLUTION_REL,
                                     HYPERVOLUME_ROUNDS, MAX_ROUNDS, Refinement)
from optdesign.quantities import get_quantity

DEFAULT_POINTS = 12
MAX_POINTS = COUNTS["points"]

#: the section's keys (docs/problem-file.md is generated from them)
DECLARATION = Key(
    "pareto", "mapping", "sweep settings of optdesign pareto (docs/pareto.md)",
    default_text="every default", nullable=True, keys=(
        Key("points", "integer", "ε values per phase count, both ends included (--points "
            "overrides it)", default=DEFAULT_POINTS, lower=2, upper=MAX_POINTS),
        Key("against", "choice", "the quantity the ripple is traded against: the ratio, or a "
            "quantity of the design such as housing_radius (docs/quantities.md)",
            default="ratio", choices=lambda: axis_choices()),
        Key("ratio_lower", "number", "sweep ε from this ratio", unit="-", lower=0,
            open_lower=True, default_text="the least-ripple design's ratio", example=0.5),
        Key("ratio_upper", "number", "... to this ratio (must exceed ratio_lower)", unit="-",
            lower=0, open_lower=True, default_text="the largest ratio the linkage reaches",
            example=0.8),
        Key("resolution", "mapping", "the scales a designer reads the front at: no point is "
            "added between neighbours that differ by less in both δ and the quantity swept "
            "against (docs/pareto.md)", default={"delta": DEFAULT_DELTA_RESOLUTION},
            default_text="delta 1e-4; the ratio (or the "
            f"quantity) {GAIN_RESOLUTION_REL:g} of its value", keys=(
                Key("delta", "number", "δ's resolution", unit="-",
                    default=DEFAULT_DELTA_RESOLUTION, lower=0, open_lower=True, upper=1),
                *(Key(name, "number", f"the resolution of {name}",
                      unit=get_quantity(name).unit, lower=0, open_lower=True,
                      default_text=f"{GAIN_RESOLUTION_REL:g} of its value",
                      condition="" if name == "ratio" else f"with against: {name}")
                  for name in axis_choices()))),
        Key("counts", "list", "phase counts to sweep", item=Key("counts", "integer",
            "a phase count", lower=1), min_items=1, default_text="every admissible count",
            example=[6], condition="each one the design admits"),
        Key("refine", "mapping", "after the uniform pass, more ε values where the front is "
            f"coarse (at most {MAX_ROUNDS} rounds a count, then at most "
            f"{HYPERVOLUME_ROUNDS} over every count together)",
            default={"enabled": True, "max_gap": DEFAULT_MAX_GAP,
                     "max_points": DEFAULT_MAX_POINTS, "max_turn_deg": DEFAULT_MAX_TURN_DEG,
                     "hypervolume_gap": DEFAULT_HYPERVOLUME_GAP,
                     "hypervolume_points": DEFAULT_HYPERVOLUME_POINTS},
            keys=(
                Key("enabled", "bool", "refine at all", default=True),
                Key("max_gap", "number", "refine until neighbours lie at most this far apart "
                    "in normalised (ratio, δ) distance (the count's front spans [0, 1] in both)",
                    unit="-", default=DEFAULT_MAX_GAP, lower=0, open_lower=True, upper=2),
                Key("max_points", "integer", "most refined points per phase count",
                    default=DEFAULT_MAX_POINTS, lower=0, upper=MAX_POINTS),
                Key("max_turn_deg", "number", "also refine where the slope dδ/d ratio "
                    "(normalised) turns by more than this between neighbours", unit="deg",
                    default=DEFAULT_MAX_TURN_DEG, lower=0, open_lower=True, upper=90),
                Key("hypervolume_gap", "number", "then, on the front of every count together "
                    "(normalised to span [0, 1] in ratio and δ), refine until no two "
                    "neighbours leave more than this area (Δratio·Δδ) of the hypervolume "
                    "uncovered", unit="-", default=DEFAULT_HYPERVOLUME_GAP, lower=0,
                    open_lower=True, upper=1),
                Key("hypervolume_points", "integer", "most points those rounds add in all (0: "
                    "none)", default=DEFAULT_HYPERVOLUME_POINTS, lower=0, upper=MAX_POINTS),
            )),
    ))
KEYS = names(DECLARATION.keys)
REFINE_KEYS = names(DECLARATION.key("refine").keys)


@dataclass(frozen=True)
class ParetoSection:
    points: int = DEFAULT_POINTS
    against: str = "ratio"
    ratio_lower: float | None = None
    ratio_upper: float | None = None
    counts: tuple[int, ...] | None = None
    refine: Refinement = Refinement()
    source: str = "<dict>"

    def check_problem(self, problem) -> None:
        """Counts must be admissible for the problem's phase-count variable."""
        if self.counts is None:
            return
        admissible = problem.counts()
        wrong = [n for n in self.counts if n not in admissible]
        if wrong:
            from optdesign.errors import ProblemError
            raise ProblemError(f"{self.source}: pareto.counts {wrong} not admissible for "
                               f"design.{problem.model.count_variable} (admissible: "
                               f"{', '.join(map(str, admissible))})")


def parse_section(raw, reader) -> ParetoSection:
    """Strict reading of ``pareto:`` (``reader`` names the file and the key path in errors)."""
    raw, kw = DECLARATION.read_given(reader, raw, ("points", "against", "ratio_lower",
                                                  "ratio_upper"))
    if kw.get("against", "ratio") != "ratio":
        for key in ("ratio_lower", "ratio_upper"):
            if key in kw:
                raise reader.error(key, f"bounds the ratio's sweep; a front against "
                                        f"{kw['against']} spans what each count reaches")
    if "ratio_lower" in kw and "ratio_upper" in kw and kw["ratio_upper"] <= kw["ratio_lower"]:
        raise reader.error("ratio_upper", f"must exceed ratio_lower (got {kw['ratio_upper']:g}"
                                          f" <= {kw['ratio_lower']:g})")
    if "counts" in raw:
        items = raw["counts"]
        if not isinstance(items, list) or not items:
            raise reader.error("counts", "must be a non-empty list of phase counts")
        kw["counts"] = tuple(sorted({reader.integer(c, "counts", 1) for c in items}))
    if "refine" in raw:
        block = reader.mapping({} if raw["refine"] is None else raw["refine"], "refine")
        reader.known_keys(block, "refine", REFINE_KEYS)
        declared = DECLARATION.key("refine")
        kw["refine"] = Refinement(**{k: declared.key(k).read(reader, v, f"refine.{k}")
                                     for k, v in block.items()})
    if raw.get("resolution") is not None:
        kw["refine"] = _resolution(reader, raw["resolution"], kw.get("against", "ratio"),
                                   kw.get("refine", Refinement()))
    return ParetoSection(**kw)


def _resolution(reader, raw, against: str, refine: Refinement) -> Refinement:
    """``resolution: {delta, AGAINST}`` into the refinement's settings."""
    block = reader.mapping(raw, "resolution")
    reader.known_keys(block, "resolution", {"delta", against})
    declared = DECLARATION.key("resolution")
    values = {k: declared.key(k).read(reader, v, f"resolution.{k}") for k, v in block.items()}
    sign = 1.0          # a resolution is a size: the gain's sign does not matter
    return replace(refine, delta_resolution=values.get("delta", refine.delta_resolution),
                   gain_resolution=sign * values[against] if against in values
                   else refine.gain_resolution)

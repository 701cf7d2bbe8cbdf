"""The ``pareto:`` section of a problem file: how ``optdesign pareto`` sweeps the front.

Registered in ``optdesign.problem.SECTION_PARSERS``; every key is optional::

    pareto:
      points: 12            # ε values per phase count, end points included (default 12)
      ratio_lower: 0.5      # sweep ε from here ... (default: the least-ripple design's ratio)
      ratio_upper: 0.8      # ... to here (default: the largest ratio the linkage reaches)
      counts: [4, 6]        # phase counts to sweep (default: every admissible count)

The ε range is always clipped to what each phase count can reach, so a span wider than the
achievable range is harmless; a span that misses it leaves that count with no sweep points.
"""
from __future__ import annotations

from dataclasses import dataclass

KEYS = {"points", "ratio_lower", "ratio_upper", "counts"}
DEFAULT_POINTS = 12
MAX_POINTS = 1000


@dataclass(frozen=True)
class ParetoSection:
    points: int = DEFAULT_POINTS
    ratio_lower: float | None = None
    ratio_upper: float | None = None
    counts: tuple[int, ...] | None = None
    source: str = "<dict>"

    def check_problem(self, problem) -> None:
        """Counts must be admissible for the problem's phase-count variable."""
        if self.counts is None:
            return
        admissible = problem.counts()
        wrong = [n for n in self.counts if n not in admissible]
        if wrong:
            from ..errors import ProblemError
            raise ProblemError(f"{self.source}: pareto.counts {wrong} not admissible for "
                               f"design.{problem.model.count_variable} (admissible: "
                               f"{', '.join(map(str, admissible))})")


def parse_section(raw, reader) -> ParetoSection:
    """Strict reading of ``pareto:`` (``reader`` names the file and the key path in errors)."""
    raw = reader.mapping({} if raw is None else raw, "")
    reader.known_keys(raw, "", KEYS)
    kw = {"source": reader.where}
    if "points" in raw:
        kw["points"] = reader.integer(raw["points"], "points", 2)
        if kw["points"] > MAX_POINTS:
            raise reader.error("points", f"must be at most {MAX_POINTS} (got {kw['points']})")
    for key in ("ratio_lower", "ratio_upper"):
        if key in raw:
            kw[key] = reader.number(raw[key], key, positive=True)
    if "ratio_lower" in kw and "ratio_upper" in kw and kw["ratio_upper"] <= kw["ratio_lower"]:
        raise reader.error("ratio_upper", f"must exceed ratio_lower (got {kw['ratio_upper']:g}"
                                          f" <= {kw['ratio_lower']:g})")
    if "counts" in raw:
        items = raw["counts"]
        if not isinstance(items, list) or not items:
            raise reader.error("counts", "must be a non-empty list of phase counts")
        kw["counts"] = tuple(sorted({reader.integer(c, "counts", 1) for c in items}))
    return ParetoSection(**kw)

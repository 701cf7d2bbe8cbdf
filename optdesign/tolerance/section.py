"""The ``tolerances:`` section of a problem file: how the parts of a design deviate when made.

Registered in ``optdesign.problem.loader.SECTION_PARSERS``; every key is optional::

    tolerances:
      default: 0.05         # ± mm of every length without an entry of its own
      lengths: {l3: 0.02}   # ± mm per length (0: made exactly)
      distribution: uniform # or normal, with k·σ = the tolerance (cut at ± the tolerance)
      k: 3                  # σ multiplier of the normal distribution
      samples: 10000        # Monte Carlo parts
      seed: 0               # of the Monte Carlo sample

A tolerance applies to a length itself, fixed or free alike; for the regulated length (the
crank) it is the length at full eccentricity, scaled by e like the nominal. The phase count
has none. What ``optdesign tolerance`` does with them: docs/tolerance.md.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping

from optdesign.declarations import Key, names
from optdesign.errors import ProblemError
from optdesign.limits import COUNTS
from optdesign.mechanisms import get_mechanism, known

DEFAULT_TOLERANCE_MM = 0.05
DISTRIBUTIONS = ("uniform", "normal")
DEFAULT_K = 3.0
DEFAULT_SAMPLES = 10_000
MAX_SAMPLES = COUNTS["parts"]
MAX_SEED = 2**32 - 1


def _length_keys() -> tuple[Key, ...]:
    """One key per length of every registered mechanism (the file's mechanism's own are
    checked at load: :meth:`ToleranceSection.check_problem`)."""
    out: dict[str, Key] = {}
    for mechanism in known():
        mech = get_mechanism(mechanism)
        for name in mech.lengths:
            if name not in out:
                out[name] = Key(name, "number", f"± of {mech.spec(name).meaning}",
                                unit="mm", lower=0, default_text="tolerances.default",
                                example=0.02, condition=f"{mechanism} only")
    return tuple(out.values())


#: the section's keys (docs/problem-file.md is generated from them)
DECLARATION = Key(
    "tolerances", "mapping", "manufacturing tolerances of the lengths, for optdesign tolerance "
    "(docs/tolerance.md)", default_text="every default", nullable=True, keys=(
        Key("default", "number", "± of every length without an entry in lengths",
            unit="mm", default=DEFAULT_TOLERANCE_MM, lower=0),
        Key("lengths", "mapping", "± per length, by the design key's name (0: made exactly)",
            default_text="every length at tolerances.default", example={}, keys=_length_keys()),
        Key("distribution", "choice", "how the Monte Carlo parts deviate: uniform over ± the "
            "tolerance, or normal with k·σ = the tolerance (cut at ± the tolerance: a part "
            "beyond it is rejected at inspection)", default="uniform", choices=DISTRIBUTIONS),
        Key("k", "number", "σ multiplier of the normal distribution: σ = tolerance / k",
            unit="-", default=DEFAULT_K, lower=0, open_lower=True, upper=100),
        Key("samples", "integer", "Monte Carlo parts (--samples overrides it)", unit="-",
            default=DEFAULT_SAMPLES, lower=1, upper=MAX_SAMPLES),
        Key("seed", "integer", "seed of the Monte Carlo sample (--seed overrides it)",
            default=0, lower=0, upper=MAX_SEED),
    ))
KEYS = names(DECLARATION.keys)


@dataclass(frozen=True)
class ToleranceSection:
    """The parsed ``tolerances:`` section."""

    default: float = DEFAULT_TOLERANCE_MM
    lengths: Mapping[str, float] = field(default_factory=dict)
    distribution: str = "uniform"
    k: float = DEFAULT_K
    samples: int = DEFAULT_SAMPLES
    seed: int = 0
    source: str = "<dict>"

    def band(self, mechanism: str) -> dict[str, float]:
        """± mm of every length of ``mechanism``, in its parameter order."""
        return {k: float(self.lengths.get(k, self.default))
                for k in get_mechanism(mechanism).lengths}

    def check_problem(self, problem) -> None:
        """Every named length is one of the mechanism's, and no tolerance reaches a length's
        least value (a part of zero or negative length)."""
        mech = problem.model
        for name in self.lengths:
            if name not in mech.lengths:
                what = ("is the count, which has no tolerance" if name == mech.count_variable
                        else f"is not a length of {problem.mechanism}")
                raise ProblemError(f"{self.source}: tolerances.lengths.{name} {what} "
                                   f"(lengths: {', '.join(mech.lengths)})")
        for name, tol in self.band(problem.mechanism).items():
            var = problem.design[name]
            least = var.value if var.value is not None else var.lower
            if tol >= least:
                key = f"tolerances.lengths.{name}" if name in self.lengths else \
                    "tolerances.default"
                raise ProblemError(f"{self.source}: {key} must be below the least value of "
                                   f"design.{name}, {least:g} mm (got {tol:g}); a part would "
                                   f"have no length")


def parse_section(raw, reader) -> ToleranceSection:
    """Strict reading of ``tolerances:`` (``reader`` names the file and the key path)."""
    raw, kw = DECLARATION.read_given(reader, raw, ("default", "distribution", "k", "samples",
                                                  "seed"))
    if raw.get("lengths") is not None:
        items = reader.mapping(raw["lengths"], "lengths")
        declared = DECLARATION.key("lengths")
        lengths = {}
        for name, value in items.items():
            key = next((k for k in declared.keys if k.name == name), None) or \
                Key(name, "number", "", unit="mm", lower=0)
            lengths[name] = key.read(reader, value, f"lengths.{name}")
        kw["lengths"] = lengths
    return ToleranceSection(**kw)

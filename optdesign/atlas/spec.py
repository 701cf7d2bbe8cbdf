"""An atlas file, read strictly: the mechanism, its design box relative to the regulated
length, the axes and the values held fixed (docs/atlas.md).

δ and the ratio depend on the lengths' proportions only (the envelope scales with the crank
and with ω1), so every cell is solved with the regulated length at 1 and ω1 = 1 rad/s, and
its optimum holds for a machine of any size: multiply every length by the crank's length.
Each cell is an ordinary problem (:func:`optdesign.problem.loader.problem_from_dict`) built
from the atlas file and the cell's values, so a cell is held to every rule a problem file is.

Every error is a :class:`~optdesign.errors.ProblemError` of one line naming the file and the
key: ``atlas.yaml: axes.phases.step must be positive (got 0)``.
"""
from __future__ import annotations

import itertools
import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from optdesign.errors import ProblemError, UnitWarning
from optdesign.limits import COUNTS
from optdesign.mechanisms import get_mechanism
from optdesign.problem.loader import MAX_COUNT, Reader, name_from_stem, problem_from_dict
from optdesign.problem.yaml_text import parse, read_text

#: mechanisms an atlas supports: those whose figures are independent of scale and whose
#: constraints the axes name (the four-bar's min_pin_radius)
SUPPORTED = ("fourbar_converter",)

#: the axes an atlas may sweep (or hold fixed), each with where it goes in a cell's problem
#: and what it means
AXES = {
    "phases": "the phase count (rockers and freewheels)",
    "min_transmission_angle_deg": "the least transmission angle allowed [deg]",
    "min_pin_radius": "the least pin radius, relative to the regulated length",
    "min_ratio": "the least ratio (output / input speed)",
    "stroke": "the stroke that drives: forward or reverse",
}
#: an axis's value when the file gives it neither as an axis nor under ``fixed:``
DEFAULTS = {"min_transmission_angle_deg": 40.0, "min_pin_radius": 0.0, "min_ratio": 0.0,
            "stroke": "forward"}
TOP_KEYS = {"name", "mechanism", "design", "axes", "fixed", "objective", "options", "solver",
            "regulation"}
OBJECTIVE_KEYS = {"minimize", "ripple"}
RANGE_KEYS = {"lower", "upper", "step"}
#: most cells of one atlas, and most values of one axis
MAX_CELLS = COUNTS["cells"]
MAX_VALUES = COUNTS["axis_values"]
#: the crank speed of every cell [rad/s]: δ and the ratio do not depend on it
INPUT_SPEED = 1.0


@dataclass(frozen=True)
class Cell:
    """One point of the atlas: its index in the grid, its position on each axis, and its
    axes' values."""

    index: int
    position: tuple[int, ...]
    values: dict = field(hash=False)


@dataclass(frozen=True)
class AtlasSpec:
    """An atlas as read from its file.

    Attributes
    ----------
    name, mechanism, source : str
        The atlas's name, the mechanism's registry name, the file's name (for messages).
    axes : dict
        ``{axis: tuple of values}`` in the file's order.
    fixed : dict
        The value of every other axis (given under ``fixed:`` or its default).
    base : dict
        The problem every cell shares (a problem file's mapping without the axes' values).
    """

    name: str
    mechanism: str
    source: str
    axes: dict = field(hash=False)
    fixed: dict = field(hash=False)
    base: dict = field(hash=False)

    @property
    def regulated(self) -> str:
        """The design key the lengths are relative to (the four-bar's crank ``l1``)."""
        return get_mechanism(self.mechanism).regulating_variable

    @property
    def lengths(self) -> tuple[str, ...]:
        return tuple(get_mechanism(self.mechanism).lengths)

    @property
    def count_name(self) -> str:
        return get_mechanism(self.mechanism).count_variable

    def shape(self) -> tuple[int, ...]:
        return tuple(len(v) for v in self.axes.values())

    def cells(self) -> list[Cell]:
        """Every cell, the last axis varying fastest."""
        names = list(self.axes)
        return [Cell(i, pos, {n: self.axes[n][k] for n, k in zip(names, pos)})
                for i, pos in enumerate(itertools.product(*(range(n) for n in self.shape())))]

    def values_of(self, cell: Cell) -> dict:
        """Every axis's value at ``cell``: its own axes' values and the fixed ones."""
        return dict(self.fixed) | dict(cell.values)

    def problem(self, cell: Cell):
        """The cell's problem, built and checked by the problem loader."""
        return cell_problem(self.base, self.values_of(cell), self.source,
                            f"{self.name}_cell{cell.index}")


def cell_problem(base: dict, values: dict, where: str, name: str):
    """The problem of a cell: ``base`` with the axes' ``values`` put where a problem file
    holds them."""
    data = {**base, "name": name, "input_speed": INPUT_SPEED, "stroke": values["stroke"]}
    data["design"] = dict(base["design"]) | {"phases": int(values["phases"])}
    data["constraints"] = {"min_transmission_angle_deg": values["min_transmission_angle_deg"],
                           "min_pin_radius": values["min_pin_radius"]}
    data["objective"] = dict(base.get("objective", {})) | {"min_ratio": values["min_ratio"]}
    with warnings.catch_warnings():     # lengths relative to a crank of 1 are no unit slip
        warnings.simplefilter("ignore", UnitWarning)
        return problem_from_dict(data, where=where, default_name=name)


def load_atlas(path: str | Path) -> AtlasSpec:
    """Read and check an atlas file (within the problem reader's limits on the file)."""
    path = Path(path)
    where = "".join(c if c.isprintable() else "?" for c in path.name) or str(path)
    data = parse(read_text(path), where)
    if data is None:
        raise ProblemError(f"{where}: the file is empty")
    return atlas_from_dict(data, where, name_from_stem(path.stem))


def atlas_from_dict(data: Any, where: str = "<dict>", default_name: str = "atlas") -> AtlasSpec:
    """Check an atlas given as a mapping (what its YAML file holds)."""
    r = Reader(where)
    top = r.mapping(data, "")
    r.known_keys(top, "", TOP_KEYS)
    for key in ("mechanism", "design", "axes"):
        if key not in top:
            raise r.error(key, "is required")
    mechanism = r.text(top["mechanism"], "mechanism")
    if mechanism not in SUPPORTED:
        raise r.error("mechanism", f"an atlas supports {', '.join(SUPPORTED)} only (got "
                                   f"{mechanism!r}): its axes name that mechanism's rules")
    name = r.text(top.get("name", default_name), "name")
    model = get_mechanism(mechanism)
    design = _read_design(r, top["design"], model)
    axes = _read_axes(r, top["axes"], model)
    fixed = _read_fixed(r, top.get("fixed", {}), model, axes)
    objective = r.mapping(top.get("objective", {}), "objective")
    r.known_keys(objective, "objective", OBJECTIVE_KEYS)
    if objective.get("minimize", "ripple") != "ripple":
        raise r.error("objective.minimize", f"an atlas maps the least ripple: give minimize: "
                                            f"ripple (got {objective['minimize']!r})")
    base = {"mechanism": mechanism, "design": design, "objective": objective}
    for key in ("options", "solver", "regulation"):     # fractions and settings: scale-free
        if key in top:
            base[key] = r.mapping(top[key], key)
    spec = AtlasSpec(name, mechanism, where, axes, fixed, base)
    n_cells = math.prod(spec.shape())
    if n_cells > MAX_CELLS:
        raise r.error("axes", f"make {n_cells} cells; at most {MAX_CELLS}")
    for values in _corners(spec):        # the loader's checks of the design and the rules
        cell_problem(base, values, where, name)
    return spec


def _read_design(r: Reader, raw, model) -> dict:
    """The design box relative to the regulated length, which is 1 (and may be left out)."""
    raw = r.mapping(raw, "design")
    reg, count = model.regulating_variable, model.count_variable
    r.known_keys(raw, "design", set(model.lengths))
    if reg in raw and raw[reg] != 1:
        raise r.error(f"design.{reg}", f"is the length every other is relative to: leave it "
                                       f"out or give 1 (got {raw[reg]!r})")
    for key in model.lengths:
        if key != reg and key not in raw:
            raise r.error(f"design.{key}", f"is required (relative to {reg}: a number or "
                                           f"{{lower, upper}})")
    return dict(raw) | {reg: 1, count: 2}      # the count is the cell's (replaced per cell)


def _read_axes(r: Reader, raw, model) -> dict:
    raw = r.mapping(raw, "axes")
    r.known_keys(raw, "axes", set(AXES))
    if not raw:
        raise r.error("axes", "must name at least one axis")
    return {name: _read_values(r, value, f"axes.{name}", name, model)
            for name, value in raw.items()}


def _read_fixed(r: Reader, raw, model, axes: dict) -> dict:
    raw = r.mapping(raw, "fixed")
    r.known_keys(raw, "fixed", set(AXES))
    for name in raw:
        if name in axes:
            raise r.error(f"fixed.{name}", "is an axis too; give it in one place")
    fixed = {}
    for name in AXES:
        if name in axes:
            continue
        if name in raw:
            fixed[name] = _one(r, raw[name], f"fixed.{name}", name, model)
        elif name in DEFAULTS:
            fixed[name] = DEFAULTS[name]
        else:
            raise r.error(f"fixed.{name}", f"is required when {name} is not an axis "
                                           f"({AXES[name]})")
    return fixed


def _read_values(r: Reader, value, key: str, name: str, model) -> tuple:
    """An axis's values: a list, or a range {lower, upper, step} (numbers only)."""
    if isinstance(value, list):
        if not value:
            raise r.error(key, "must hold at least one value")
        if len(value) > MAX_VALUES:
            raise r.error(key, f"holds {len(value)} values; at most {MAX_VALUES}")
        values = tuple(_one(r, v, key, name, model) for v in value)
        if len(set(values)) != len(values):
            raise r.error(key, f"repeats a value ({', '.join(map(str, values))})")
        return values
    if name == "stroke" or not isinstance(value, dict):
        raise r.error(key, "must be a list of values" + (
            "" if name == "stroke" else " or a range {lower, upper, step}"))
    entry = r.mapping(value, key)
    r.known_keys(entry, key, RANGE_KEYS)
    for bound in ("lower", "upper", "step"):
        if bound not in entry:
            raise r.error(f"{key}.{bound}", "is required in a range")
    lower, upper = (_one(r, entry[b], f"{key}.{b}", name, model) for b in ("lower", "upper"))
    step = r.number(entry["step"], f"{key}.step")
    if step <= 0:
        raise r.error(f"{key}.step", f"must be positive (got {step:g})")
    if name == "phases" and step != int(step):
        # a count steps by whole numbers: 3, 3.5, 4 would be rounded into repeated cells
        raise r.error(f"{key}.step", f"must be a whole number: the count takes whole values "
                                     f"(got {step:g})")
    if upper < lower:
        raise r.error(f"{key}.upper", f"must not be below lower (got {upper:g} < {lower:g})")
    n = int(math.floor((upper - lower) / step + 1e-9)) + 1
    if n > MAX_VALUES:
        raise r.error(key, f"makes {n} values; at most {MAX_VALUES}")
    values = [round(lower + k * step, 12) for k in range(n)]
    return tuple(int(v) for v in values) if name == "phases" else tuple(values)


def _one(r: Reader, value, key: str, name: str, model):
    """One value of an axis, checked by its kind."""
    if name == "phases":
        spec = next(v for v in model.variables if v.name == model.count_variable)
        return r.integer(value, key, int(spec.minimum), MAX_COUNT)
    if name == "stroke":
        return r.choice(value, key, model.strokes)
    number = r.number(value, key)
    if number < 0:
        raise r.error(key, f"must not be negative (got {number:g})")
    if name == "min_transmission_angle_deg" and number >= 90:
        raise r.error(key, f"must be below 90 deg (got {number:g})")
    return number


def _corners(spec: AtlasSpec):
    """The values of the cells at the corners of the grid (each axis at its first and last
    value): the loader checks them as it checks a problem file."""
    ends = [sorted({v[0], v[-1]}, key=str) for v in spec.axes.values()]
    for combo in itertools.product(*ends):
        yield dict(spec.fixed) | dict(zip(spec.axes, combo))

"""The ``dynamics:`` section of a problem file, read strictly (Ambartsumyants & Subbotina 2015).

It is parsed only when present, and it has no ``analyze`` method: the drive dynamics run under
``optdesign simulate`` alone (docs/formulation.md, "What a problem builds").

Keys (SI units, as in the paper)::

    dynamics:
      I1: 0.014              # kg·m², input side reduced to the crank (motor, converter, holders)
      I2: 0.05               # kg·m², output side reduced to the output shaft
      stiffness: 2877        # N·m/rad, freewheel stiffness λ: one value or one per phase
      damping_ratio: 0       # ζ of the freewheel, c = 2ζ·√(λ·I2); 0 in the paper
      motor: {a: 230, b: 2.35}   # static characteristic T = a - b·ω (N·m, N·m·s)
      load: 15               # N·m resisting the output; or {angle_deg: [...], torque: [...]}
      cycles: 200            # most crank turns simulated, the reported (last) one included
      reduction: 1.0         # freewheel holder angle per radian of the mechanism's output member
      freewheel: ratchet     # ratchet (each freewheel slips, engages at speed match) | composite
      crank: dynamic         # dynamic (two-mass, motor characteristic) | constant (φ = ω1·t)
      method: Radau          # Radau | BDF | LSODA (implicit) | RK45 (explicit, comparison only)
      rtol: 1.0e-8           # relative tolerance of the integrator
      atol: 1.0e-10          # absolute tolerance on angles, rad (speeds: atol·ω1)
      steady_tol: 1.0e-6     # relative change of the state over a turn that counts as steady

Every number must lie in its range of :data:`RANGES` (docs/dynamics.md lists them): a denormal
inertia or an overflowing stiffness would otherwise reach the integrator as inf or NaN.
"""
from __future__ import annotations

from dataclasses import dataclass

from optdesign.declarations import Key, REQUIRED as REQUIRED_KEY
from optdesign.errors import ProblemError
from optdesign.limits import COUNTS

METHODS = ("Radau", "BDF", "LSODA", "RK45")
FREEWHEEL_MODELS = ("ratchet", "composite")
CRANK_MODELS = ("dynamic", "constant")
KEYS = {"I1", "I2", "stiffness", "damping_ratio", "motor", "load", "cycles", "reduction",
        "freewheel", "crank", "method", "rtol", "atol", "steady_tol"}
REQUIRED = ("I1", "I2", "stiffness", "motor", "load")
MAX_CYCLES = COUNTS["cycles"]
MIN_ANGLE_STEP_DEG = 1e-6     # load table: closer points make its slope overflow
#: key -> (lower, upper, unit): the magnitudes the integrator is trusted with. The bounds are
#: far outside any drive (1e-8 kg·m² is a steel disc 1 cm across; 1e10 N·m/rad is stiffer
#: than a ship's propeller shaft) and far inside the float range, so λ/I, a/b and every
#: product stay finite.
#: ``load`` and ``load.torque`` may also be exactly 0.
RANGES = {
    "I1": (1e-8, 1e6, "kg·m²"), "I2": (1e-8, 1e6, "kg·m²"),
    "stiffness": (1e-2, 1e10, "N·m/rad"),
    "motor.a": (1e-6, 1e9, "N·m"), "motor.b": (1e-9, 1e9, "N·m·s"),
    "load": (1e-9, 1e9, "N·m"), "load.torque": (1e-9, 1e9, "N·m"),
    "reduction": (1e-3, 1e3, ""),
    "rtol": (1e-13, 1e-2, ""), "atol": (1e-15, 1e-2, "rad"), "steady_tol": (1e-13, 1e-2, ""),
}


@dataclass(frozen=True)
class LoadTable:
    """Resisting torque over one turn of the output shaft, linear between points, periodic."""

    angle_deg: tuple[float, ...]
    torque: tuple[float, ...]


@dataclass(frozen=True)
class DynamicsSection:
    """The parsed ``dynamics:`` section (no ``analyze``: it runs only under ``simulate``)."""

    I1: float
    I2: float
    stiffness: tuple[float, ...]          # one value, or one per phase
    motor_a: float
    motor_b: float
    load: float | LoadTable
    damping_ratio: float = 0.0
    cycles: int = 200
    reduction: float = 1.0
    freewheel: str = "ratchet"
    crank: str = "dynamic"
    method: str = "Radau"
    rtol: float = 1e-8
    atol: float = 1e-10
    steady_tol: float = 1e-6

    def stiffness_per_phase(self, count: int) -> tuple[float, ...]:
        return self.stiffness * count if len(self.stiffness) == 1 else self.stiffness

    def check_problem(self, problem) -> None:
        """What the section asks of the rest of the file, checked when it is loaded: one
        stiffness or one per phase of every admissible count."""
        for count in problem.counts():
            if len(self.stiffness) not in (1, count):
                raise ProblemError(f"{problem.source}: dynamics.stiffness must have one value "
                                   f"or one per phase (got {len(self.stiffness)} for {count} "
                                   f"phases)")


#: the motor's no-load speed a/b against input_speed: refused outside [lower, upper] times
#: it (a/b below ω1: the crank never reaches it; far above: the motor drives the crank far
#: faster than the file says, e.g. a motor's characteristic given at the motor shaft of a
#: gearbox instead of at the crank), warned above ``warned`` times it
MOTOR_SPEEDS = {"lower": 1.0, "warned": 1.25, "upper": 2.0}


def check_motor_speed(section, problem) -> None:
    """ProblemError when the motor's no-load speed a/b is far from ``input_speed``, naming
    both; a UnitWarning when it is somewhat above it. Checked by ``simulate`` with the
    dynamic crank (a file whose section is not simulated is not held to it)."""
    if section.crank != "dynamic":
        return
    import warnings

    from optdesign.errors import UnitWarning

    free = section.motor_a / section.motor_b
    w1 = problem.input_speed
    both = (f"the motor's no-load speed a/b = {section.motor_a:g}/{section.motor_b:g} = "
            f"{free:.4g} rad/s against input_speed {w1:g} rad/s")
    if free < MOTOR_SPEEDS["lower"] * w1:
        raise ProblemError(f"{problem.source}: dynamics.motor: {both}: the crank never reaches "
                           f"input_speed (give the characteristic at the crank)")
    if free > MOTOR_SPEEDS["upper"] * w1:
        raise ProblemError(f"{problem.source}: dynamics.motor: {both} ({free / w1:.1f} times "
                           f"it): the motor would drive the crank near {free:.4g} rad/s; give "
                           f"the characteristic at the crank (a·r, b·r² through a reduction "
                           f"r) or input_speed as the crank's speed")
    if free > MOTOR_SPEEDS["warned"] * w1:
        warnings.warn(UnitWarning(f"{problem.source}: dynamics.motor: {both}: the crank will "
                                  f"turn faster than input_speed"), stacklevel=3)


def _ranged_key(name: str, meaning: str, range_of: str | None = None, **kw) -> Key:
    """A number key whose range (and unit) is ``RANGES[range_of or name]``."""
    lower, upper, unit = RANGES[range_of or name]
    return Key(name, "number", meaning, unit=unit or "-", lower=lower, upper=upper, **kw)


_DEFAULTS = DynamicsSection.__dataclass_fields__
#: the section's keys (docs/problem-file.md is generated from them; ranges from RANGES,
#: defaults from DynamicsSection); docs/dynamics.md explains each
DECLARATION = Key(
    "dynamics", "mapping", "compliant freewheels for optdesign simulate (docs/dynamics.md; SI "
    "units)", default_text="none (simulate refuses the file)", keys=(
        _ranged_key("I1", "inertia of the input side reduced to the crank (motor rotor, "
                    "converter, driving holders)", default=REQUIRED_KEY, example=0.014),
        _ranged_key("I2", "inertia of the output side reduced to the output shaft",
                    default=REQUIRED_KEY, example=0.05),
        Key("stiffness", "either", "freewheel stiffness λ: one value, or one per phase",
            unit=RANGES["stiffness"][2], default=REQUIRED_KEY, example=2877, alternatives=(
                _ranged_key("stiffness", "one value for every freewheel"),
                Key("stiffness", "list", "one value per phase", min_items=1,
                    item=_ranged_key("stiffness", "a freewheel's stiffness")))),
        Key("damping_ratio", "number", "ζ of the freewheel, c = 2ζ·√(λ·I2)", unit="-",
            default=_DEFAULTS["damping_ratio"].default, lower=0, upper=1),
        Key("motor", "mapping", "static motor characteristic T = a − b·ω at the crank",
            default=REQUIRED_KEY, example={"a": 230, "b": 2.35}, keys=(
                _ranged_key("a", "stall torque a", range_of="motor.a", default=REQUIRED_KEY),
                _ranged_key("b", "slope b", range_of="motor.b", default=REQUIRED_KEY))),
        Key("load", "either", "resisting torque on the output: a number, or a table over one "
            "output turn (linear between points, periodic)", unit=RANGES["load"][2],
            default=REQUIRED_KEY, example=13, alternatives=(
                Key("load", "number", "no load", lower=0, upper=0),
                _ranged_key("load", "a constant torque"),
                Key("load", "mapping", "a table", keys=(
                    Key("angle_deg", "list", "output angles, strictly increasing, at least "
                        f"{MIN_ANGLE_STEP_DEG:g} deg apart", unit="deg", default=REQUIRED_KEY,
                        min_items=2, item=Key("angle_deg", "number", "an angle", lower=0,
                                              upper=360)),
                    Key("torque", "list", "torque at each angle (0 or in range)",
                        unit=RANGES["load.torque"][2], default=REQUIRED_KEY, min_items=2,
                        item=Key("torque", "either", "a torque", alternatives=(
                            Key("torque", "number", "none", lower=0, upper=0),
                            _ranged_key("torque", "a torque", range_of="load.torque")))),
                )))),
        Key("cycles", "integer", "most crank turns simulated, the reported one included",
            unit="turns", default=_DEFAULTS["cycles"].default, lower=1, upper=MAX_CYCLES),
        _ranged_key("reduction", "freewheel holder angle per radian of the mechanism's output "
                    "member", default=_DEFAULTS["reduction"].default),
        Key("freewheel", "choice", "ratchet (each freewheel slips, engages at speed match) or "
            "composite", default=_DEFAULTS["freewheel"].default, choices=FREEWHEEL_MODELS),
        Key("crank", "choice", "dynamic (two-mass model, the motor's characteristic) or "
            "constant (φ = ω1·t)", default=_DEFAULTS["crank"].default, choices=CRANK_MODELS),
        Key("method", "choice", "integrator: implicit Radau, BDF, LSODA, or explicit RK45 "
            "(comparison only)", default=_DEFAULTS["method"].default, choices=METHODS),
        _ranged_key("rtol", "relative tolerance of the integrator", open_upper=True,
                    default=_DEFAULTS["rtol"].default),
        _ranged_key("atol", "absolute tolerance on the angles (speeds: atol·ω1)",
                    default=_DEFAULTS["atol"].default),
        _ranged_key("steady_tol", "relative change of the state over a turn that counts as "
                    "steady", open_upper=True, default=_DEFAULTS["steady_tol"].default),
    ))

def parse_section(raw, reader) -> DynamicsSection:
    """Validate the ``dynamics:`` mapping; every error names ``dynamics.<key>``."""
    raw = reader.mapping(raw, "")
    reader.known_keys(raw, "", KEYS)
    for key in REQUIRED:
        if key not in raw:
            raise reader.error(key, "is required")
    kw = {key: _ranged(reader.number(raw[key], key, positive=True), key, reader)
          for key in ("I1", "I2")}
    kw["stiffness"] = _stiffness(raw["stiffness"], reader)
    motor = reader.mapping(raw["motor"], "motor")
    reader.known_keys(motor, "motor", {"a", "b"})
    for key in ("a", "b"):
        if key not in motor:
            raise reader.error(f"motor.{key}", "is required (motor torque T = a - b·ω)")
    kw["motor_a"] = _ranged(reader.number(motor["a"], "motor.a", positive=True), "motor.a",
                            reader)
    kw["motor_b"] = _ranged(reader.number(motor["b"], "motor.b", positive=True), "motor.b",
                            reader)
    kw["load"] = _load(raw["load"], reader)
    if "damping_ratio" in raw:
        kw["damping_ratio"] = reader.number(raw["damping_ratio"], "damping_ratio")
        if not 0 <= kw["damping_ratio"] <= 1:
            raise reader.error("damping_ratio", f"must lie in [0, 1] (got "
                                                f"{kw['damping_ratio']:g})")
    if "cycles" in raw:
        kw["cycles"] = reader.integer(raw["cycles"], "cycles", 1)
        if kw["cycles"] > MAX_CYCLES:
            raise reader.error("cycles", f"must be at most {MAX_CYCLES} (got {kw['cycles']})")
    for key in ("reduction", "rtol", "atol", "steady_tol"):
        if key in raw:
            kw[key] = reader.number(raw[key], key, positive=True)
    for key in ("rtol", "steady_tol"):
        if kw.get(key, 0.0) >= 1e-2:
            raise reader.error(key, f"must be below 0.01 (got {kw[key]:g})")
    for key in ("reduction", "rtol", "atol", "steady_tol"):
        if key in kw:
            _ranged(kw[key], key, reader)
    for key, choices in (("freewheel", FREEWHEEL_MODELS), ("crank", CRANK_MODELS),
                         ("method", METHODS)):
        if key in raw:
            kw[key] = reader.choice(raw[key], key, choices)
    return DynamicsSection(**kw)


def _stiffness(value, reader) -> tuple[float, ...]:
    if isinstance(value, list):
        if not value:
            raise reader.error("stiffness", "must be a number or a non-empty list (N·m/rad)")
        return tuple(_ranged(reader.number(v, "stiffness", positive=True), "stiffness", reader)
                     for v in value)
    return (_ranged(reader.number(value, "stiffness", positive=True), "stiffness", reader),)


def _ranged(value: float, key: str, reader, zero: bool = False) -> float:
    """``value`` if it lies in ``RANGES[key]`` (or is 0 where ``zero`` allows it)."""
    lower, upper, unit = RANGES[key]
    if not (lower <= value <= upper or (zero and value == 0.0)):
        unit = f" {unit}" if unit else ""
        raise reader.error(key, f"must lie in [{lower:g}, {upper:g}]{unit}"
                                f"{' or be 0' if zero else ''} (got {value:g})")
    return value


def _load(value, reader) -> float | LoadTable:
    if not isinstance(value, dict):
        torque = reader.number(value, "load")
        if torque < 0:
            raise reader.error("load", f"must not be negative (got {torque:g}); it resists "
                                       "the output")
        return _ranged(torque, "load", reader, zero=True)
    table = reader.mapping(value, "load")
    reader.known_keys(table, "load", {"angle_deg", "torque"})
    columns = {}
    for key in ("angle_deg", "torque"):
        items = table.get(key)
        if not isinstance(items, list) or len(items) < 2:
            raise reader.error(f"load.{key}", "must be a list of at least two numbers")
        columns[key] = tuple(reader.number(v, f"load.{key}") for v in items)
    angles, torques = columns["angle_deg"], columns["torque"]
    if len(angles) != len(torques):
        raise reader.error("load.torque", f"must have one value per angle (got {len(torques)} "
                                          f"for {len(angles)})")
    if any(b <= a for a, b in zip(angles, angles[1:])) or angles[0] < 0 or angles[-1] > 360:
        raise reader.error("load.angle_deg", "must increase strictly within [0, 360]")
    wrap = angles[0] + 360.0 - angles[-1]       # the table closes its period through 360°
    gaps = [b - a for a, b in zip(angles, angles[1:])] + ([wrap] if wrap > 0 else [])
    if min(gaps) < MIN_ANGLE_STEP_DEG:
        raise reader.error("load.angle_deg", f"must be at least {MIN_ANGLE_STEP_DEG:g} deg "
                                             f"apart, through 360 too (got {min(gaps):g})")
    if min(torques) < 0:
        raise reader.error("load.torque", "must not be negative; it resists the output")
    for torque in torques:
        _ranged(torque, "load.torque", reader, zero=True)
    return LoadTable(angles, torques)

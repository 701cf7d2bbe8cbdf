"""The ``dynamics:`` section of a problem file, read strictly (Ambartsumyants & Subbotina 2015).

It is parsed only when present, and it has no ``analyze`` method: the drive dynamics run under
``optdesign simulate`` alone (docs/formulation.md, "What a problem builds").

Keys (SI units, as in the paper)::

    dynamics:
      I1: 0.014              # kg·m², input side reduced to the crank (motor, converter, holders)
      I2: 0.05               # kg·m², output side reduced to the output shaft
      stiffness: 2877        # N·m/rad, freewheel stiffness λ: one value or one per phase
      damping_ratio: 0       # ζ of the freewheel, c = 2ζ·√(λ·I2); 0 in the paper (ratchet only)
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
"""
from __future__ import annotations

from dataclasses import dataclass

from ..errors import ProblemError

METHODS = ("Radau", "BDF", "LSODA", "RK45")
FREEWHEEL_MODELS = ("ratchet", "composite")
CRANK_MODELS = ("dynamic", "constant")
KEYS = {"I1", "I2", "stiffness", "damping_ratio", "motor", "load", "cycles", "reduction",
        "freewheel", "crank", "method", "rtol", "atol", "steady_tol"}
REQUIRED = ("I1", "I2", "stiffness", "motor", "load")


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
        stiffness or one per phase of every admissible count; no damping on a composite
        freewheel (the ``simulate`` command checks its own overrides again)."""
        for count in problem.counts():
            if len(self.stiffness) not in (1, count):
                raise ProblemError(f"{problem.source}: dynamics.stiffness must have one value "
                                   f"or one per phase (got {len(self.stiffness)} for {count} "
                                   f"phases)")
        if self.freewheel == "composite" and self.damping_ratio > 0:
            raise ProblemError(f"{problem.source}: dynamics.damping_ratio must be 0 with "
                               f"freewheel: composite (got {self.damping_ratio:g})")


def parse_section(raw, reader) -> DynamicsSection:
    """Validate the ``dynamics:`` mapping; every error names ``dynamics.<key>``."""
    raw = reader.mapping(raw, "")
    reader.known_keys(raw, "", KEYS)
    for key in REQUIRED:
        if key not in raw:
            raise reader.error(key, "is required")
    kw = {key: reader.number(raw[key], key, positive=True) for key in ("I1", "I2")}
    kw["stiffness"] = _stiffness(raw["stiffness"], reader)
    motor = reader.mapping(raw["motor"], "motor")
    reader.known_keys(motor, "motor", {"a", "b"})
    for key in ("a", "b"):
        if key not in motor:
            raise reader.error(f"motor.{key}", "is required (motor torque T = a - b·ω)")
    kw["motor_a"] = reader.number(motor["a"], "motor.a", positive=True)
    kw["motor_b"] = reader.number(motor["b"], "motor.b", positive=True)
    kw["load"] = _load(raw["load"], reader)
    if "damping_ratio" in raw:
        kw["damping_ratio"] = reader.number(raw["damping_ratio"], "damping_ratio")
        if not 0 <= kw["damping_ratio"] <= 1:
            raise reader.error("damping_ratio", f"must lie in [0, 1] (got "
                                                f"{kw['damping_ratio']:g})")
    if "cycles" in raw:
        kw["cycles"] = reader.integer(raw["cycles"], "cycles", 1)
    for key in ("reduction", "rtol", "atol", "steady_tol"):
        if key in raw:
            kw[key] = reader.number(raw[key], key, positive=True)
    for key in ("rtol", "steady_tol"):
        if kw.get(key, 0.0) >= 1e-2:
            raise reader.error(key, f"must be below 0.01 (got {kw[key]:g})")
    for key, choices in (("freewheel", FREEWHEEL_MODELS), ("crank", CRANK_MODELS),
                         ("method", METHODS)):
        if key in raw:
            kw[key] = reader.text(raw[key], key)
            if kw[key] not in choices:
                raise reader.error(key, f"must be one of {', '.join(choices)} (got {kw[key]!r})")
    return DynamicsSection(**kw)


def _stiffness(value, reader) -> tuple[float, ...]:
    if isinstance(value, list):
        if not value:
            raise reader.error("stiffness", "must be a number or a non-empty list (N·m/rad)")
        return tuple(reader.number(v, "stiffness", positive=True) for v in value)
    return (reader.number(value, "stiffness", positive=True),)


def _load(value, reader) -> float | LoadTable:
    if not isinstance(value, dict):
        torque = reader.number(value, "load")
        if torque < 0:
            raise reader.error("load", f"must not be negative (got {torque:g}); it resists "
                                       "the output")
        return torque
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
    if min(torques) < 0:
        raise reader.error("load.torque", "must not be negative; it resists the output")
    return LoadTable(angles, torques)

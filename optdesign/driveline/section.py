"""The ``driveline:`` section of a problem file: the cardan shaft after the variator's output.

Registered in ``optdesign.problem.loader.SECTION_PARSERS`` and imported only when a problem file has
the section. Keys (lengths in mm, speeds in rad/s)::

    driveline:
      length_mm: 1143            # between the supports (joint centres), l
      A_mm: 100                  # correction plane 1-1 from support I
      C_mm: 100                  # correction plane 2-2 from support II
      outer_diameter_mm: 88.9    # the tube ...
      wall_mm: 2.108
      youngs_modulus_gpa: 206.8  # default 210 (steel)
      density_kg_m3: 7833        # default 7850 (steel)
      # ... or mass_per_length_kg_m and EI_n_m2 directly instead of the four above
      straightness_class: normal # normal 0.4 | increased 0.25 | high 0.15 mm/m (GOST 5005-82)
      # ... or y0_max_mm: 0.3     (default: straightness_class normal)
      balancing_speed_rad_s: 31.4   # default 0: balanced "at low speed" in the limit ω_b -> 0
      operating_speed_rad_s: 600    # default: speed_factor × the design's maximum output speed
      speed_factor: 1.0             # shaft speed / variator output speed (default 1.0)

and, in ``constraints:``, ``max_speed_fraction_of_critical: 0.7`` (operating speed at most 70 %
of the first critical speed; ``solve`` keeps it as a constraint).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from optdesign.declarations import Key, REQUIRED, names
from optdesign.driveline import model
from optdesign.errors import ProblemError, shown

TUBE_KEYS = ("outer_diameter_mm", "wall_mm", "youngs_modulus_gpa", "density_kg_m3")
DIRECT_KEYS = ("mass_per_length_kg_m", "EI_n_m2")
STEEL_YOUNGS_MODULUS_GPA = 210.0
STEEL_DENSITY_KG_M3 = 7850.0
DEFAULT_STRAIGHTNESS_CLASS = "normal"     # the loosest class: the largest initial bend
CONSTRAINT_KEY = "max_speed_fraction_of_critical"
G_MM_PER_KG_M = 1e6                       # 1 kg·m = 1e3 g × 1e3 mm
#: thinnest wall, as a fraction of the outer diameter: below it D⁴ - d⁴ loses every digit
MIN_WALL_FRACTION = 1e-6
RPM_PER_RAD_S = 30.0 / np.pi

_POSITIVE = {"lower": 0, "open_lower": True}
#: the section's keys (docs/problem-file.md is generated from them); parse_section checks
#: what they cannot say: the planes inside half the length, the wall at most half the
#: diameter, the speeds below the critical speed
DECLARATION = Key(
    "driveline", "mapping", "the cardan shaft after the output (docs/driveline.md)",
    default_text="none (no driveline figures)", keys=(
        Key("length_mm", "number", "length l between the supports (joint centres)", unit="mm",
            default=REQUIRED, example=1143, **_POSITIVE),
        Key("A_mm", "number", "correction plane 1-1 from support I, below half of length_mm",
            unit="mm", default=REQUIRED, example=80, lower=0),
        Key("C_mm", "number", "correction plane 2-2 from support II, below half of length_mm",
            unit="mm", default=REQUIRED, example=80, lower=0),
        Key("outer_diameter_mm", "number", "outer diameter D of the tube", unit="mm",
            default=REQUIRED, example=88.9, condition="unless mass_per_length_kg_m and "
            "EI_n_m2 are given", **_POSITIVE),
        Key("wall_mm", "number", "wall of the tube, at most D/2 and at least 1e-6 D", unit="mm",
            default=REQUIRED, example=2.108, condition="unless mass_per_length_kg_m and "
            "EI_n_m2 are given", **_POSITIVE),
        Key("youngs_modulus_gpa", "number", "Young's modulus of the tube (steel)", unit="GPa",
            default=STEEL_YOUNGS_MODULUS_GPA, **_POSITIVE),
        Key("density_kg_m3", "number", "density of the tube (steel)", unit="kg/m³",
            default=STEEL_DENSITY_KG_M3, **_POSITIVE),
        Key("mass_per_length_kg_m", "number", "mass per length m', with EI_n_m2",
            unit="kg/m", example=4.5, condition="instead of the four tube keys", **_POSITIVE),
        Key("EI_n_m2", "number", "bending stiffness EI, with mass_per_length_kg_m",
            unit="N·m²", example=1.12e5, condition="instead of the four tube keys",
            **_POSITIVE),
        Key("straightness_class", "choice", "straightness class of the tube (GOST 5005-82): "
            "initial bend 0.4, 0.25 or 0.15 mm per metre", default=DEFAULT_STRAIGHTNESS_CLASS,
            choices=tuple(model.GOST_5005_STRAIGHTNESS_MM_PER_M)),
        Key("y0_max_mm", "number", "initial bend at mid-span, given directly", unit="mm",
            example=0.3, condition="instead of straightness_class", **_POSITIVE),
        Key("balancing_speed_rad_s", "number", "speed of the balancing machine (0: balanced "
            "at low speed)", unit="rad/s", default=0.0, lower=0),
        Key("operating_speed_rad_s", "number", "the shaft's speed, fixed", unit="rad/s",
            default_text="speed_factor × the design's maximum output speed", example=600,
            condition="instead of speed_factor", **_POSITIVE),
        Key("speed_factor", "number", "shaft speed / the variator's output speed (a gear "
            "between them)", unit="-", default=1.0, **_POSITIVE),
    ))
KEYS = names(DECLARATION.keys)


@dataclass(frozen=True)
class DrivelineSection:
    """A cardan shaft between two supports, in SI units (see :mod:`optdesign.driveline.model`).

    ``operating_speed`` is None when the file leaves it to the design: then the shaft turns at
    ``speed_factor`` times the design's maximum output speed on the problem's stroke.
    """

    length: float                   # m, between supports
    A: float                        # m, plane 1-1 from support I
    C: float                        # m, plane 2-2 from support II
    mass_per_length: float          # kg/m
    EI: float                       # N·m²
    y0_max: float                   # m, initial bend at mid-span (eq. 11)
    y0_source: str                  # how y0_max was set, for the report
    balancing_speed: float = 0.0    # rad/s
    operating_speed: float | None = None
    speed_factor: float = 1.0
    source: str = "<dict>"          # the problem file's name, for messages

    # ------------------------------------------------------------------ derived figures
    @property
    def mass(self) -> float:
        """m = m'·l, kg (assumption 3 of the paper)."""
        return self.mass_per_length * self.length

    @property
    def critical_speed(self) -> float:
        """ω_cr, rad/s (eq. 13)."""
        return model.first_critical_speed(self.length, self.EI, self.mass_per_length)

    def figures(self, omega: float) -> dict:
        """Every figure of the model at shaft speed ``omega`` (rad/s, below ω_cr); mm, g·mm."""
        w_cr = self.critical_speed
        args = (w_cr, self.mass, self.EI, self.y0_max, self.length, self.A, self.C)
        y = model.deflection(omega, w_cr, self.y0_max)
        dk1, dk2 = model.corrections_balanced_at(omega, *args)
        low1, low2 = model.corrections_static(
            model.principal_imbalance(self.mass, model.deflection(self.balancing_speed, w_cr,
                                                                  self.y0_max)),
            self.length, self.A, self.C)
        return {
            "operating_speed_rad_s": float(omega),
            "speed_fraction_of_critical": float(omega / w_cr),
            "amplification": float(model.amplification(omega, w_cr)),
            "y_max_mm": float(y * 1e3),
            "D0_g_mm": float(model.principal_imbalance(self.mass, y) * G_MM_PER_KG_M),
            "b": float(model.coefficient_b(omega, self.mass, self.EI, self.length, self.A,
                                           self.C)),
            "Dk1_g_mm": float(dk1 * G_MM_PER_KG_M),
            "Dk2_g_mm": float(dk2 * G_MM_PER_KG_M),
            "y_max_balanced_mm": float(model.deflection_balanced_at(omega, *args) * 1e3),
            "Dk1_low_speed_g_mm": float(low1 * G_MM_PER_KG_M),
            "Dk2_low_speed_g_mm": float(low2 * G_MM_PER_KG_M),
            # the imbalance left at ω in a shaft balanced at ω_b: what eq. 16 needs beyond eq. 10
            "low_speed_residual1_g_mm": float(abs(dk1 - low1) * G_MM_PER_KG_M),
            "low_speed_residual2_g_mm": float(abs(dk2 - low2) * G_MM_PER_KG_M),
        }

    def static_figures(self) -> dict:
        """The speed-independent figures: the shaft itself, ω_cr, β, y0_max."""
        w_cr = self.critical_speed
        return {
            "critical_speed_rad_s": w_cr,
            "critical_speed_rpm": w_cr * RPM_PER_RAD_S,
            "beta_s2": model.beta(w_cr),
            "length_mm": self.length * 1e3,
            "A_mm": self.A * 1e3,
            "C_mm": self.C * 1e3,
            "mass_kg": self.mass,
            "mass_per_length_kg_m": self.mass_per_length,
            "EI_n_m2": self.EI,
            "y0_max_mm": self.y0_max * 1e3,
            "y0_max_source": self.y0_source,
            "balancing_speed_rad_s": self.balancing_speed,
        }

    # ------------------------------------------------------------------ the problem's speed
    def speed_source(self, stroke: str) -> str:
        if self.operating_speed is not None:
            return "driveline.operating_speed_rad_s"
        return f"{self.speed_factor:g} x {stroke} omega_max"

    def shaft_speed(self, problem, analysis_result) -> float | None:
        """The shaft's operating speed, rad/s: as given, or speed_factor × the design's ω_max.

        None when the design does not assemble (it has no output speed). Raises a
        :class:`ProblemError` naming the file and key at or above the critical speed.
        """
        if self.operating_speed is not None:
            return self.operating_speed
        figures = analysis_result.strokes.get(problem.stroke)
        if not analysis_result.assembles or figures is None:
            return None
        omega = self.speed_factor * figures.omega_max
        if omega >= self.critical_speed:
            raise ProblemError(
                f"{self.source}: driveline.operating_speed_rad_s (default {self.speed_factor:g}"
                f" x {problem.stroke} omega_max = {omega:.6g} rad/s) must be below the first "
                f"critical speed {self.critical_speed:.6g} rad/s; shorten the shaft, widen the "
                f"tube or lower the speed")
        return omega

    # ------------------------------------------------------------------ the section protocol
    def analyze(self, problem, analysis_result) -> dict:
        """The ``driveline`` object of ``optdesign analyze --json`` (every eq. 6-18 figure)."""
        out = self.static_figures()
        omega = self.shaft_speed(problem, analysis_result)
        out["operating_speed_source"] = self.speed_source(problem.stroke)
        if omega is None:
            out["operating_speed_rad_s"] = None
            return out
        out.update(self.figures(omega))
        out["critical_margin_rad_s"] = out["critical_speed_rad_s"] - omega
        fraction = problem.constraints.extra.get(CONSTRAINT_KEY)
        if fraction is not None:
            out[CONSTRAINT_KEY] = float(fraction)
            out["speed_limit_rad_s"] = float(fraction) * out["critical_speed_rad_s"]
            out["speed_margin_rad_s"] = out["speed_limit_rad_s"] - omega
            out["speed_constraint_holds"] = bool(omega <= out["speed_limit_rad_s"])
        return out

    def solve_constraints(self, problem, omega_out_max) -> list:
        """``[(name, g)]`` with g >= 0 when the shaft runs at most the allowed fraction of ω_cr.

        g = fraction - speed_factor·omega_out_max/ω_cr, i.e. (fraction·ω_cr - operating
        speed)/ω_cr, scaled by ω_cr to be O(1) in the NLP. ``omega_out_max`` is a CasADi
        expression of the design's maximum output speed, rad/s. Empty when the problem sets no
        ``max_speed_fraction_of_critical`` or gives ``operating_speed_rad_s`` (then the speed
        does not depend on the design and was checked when the file was loaded).
        """
        fraction = problem.constraints.extra.get(CONSTRAINT_KEY)
        if fraction is None or self.operating_speed is not None:
            return []
        g = float(fraction) - self.speed_factor * omega_out_max / self.critical_speed
        return [(f"driveline_{CONSTRAINT_KEY}", g)]

    def verify(self, problem, analysis_result, tol: float = 1e-6) -> str | None:
        """None when the design's shaft speed keeps the constraint (within ``tol`` of the
        fraction), else a one-line message; never raises for a speed past ω_cr."""
        fraction = problem.constraints.extra.get(CONSTRAINT_KEY)
        if fraction is None:
            return None
        if self.operating_speed is not None:
            omega = self.operating_speed
        else:
            figures = analysis_result.strokes.get(problem.stroke)
            if not analysis_result.assembles or figures is None:
                return "driveline: the design does not assemble, so it has no output speed"
            omega = self.speed_factor * figures.omega_max
        ratio = omega / self.critical_speed
        if ratio <= float(fraction) + tol:
            return None
        return (f"driveline: the shaft turns at {omega:.6g} rad/s, {ratio:.4g} of its critical "
                f"speed {self.critical_speed:.6g} rad/s, above {CONSTRAINT_KEY} = "
                f"{float(fraction):g}")

    def check_problem(self, problem) -> None:
        """Validate ``constraints.max_speed_fraction_of_critical`` against this section."""
        if CONSTRAINT_KEY not in problem.constraints.extra:
            return
        key = f"constraints.{CONSTRAINT_KEY}"
        value = problem.constraints.extra[CONSTRAINT_KEY]
        if isinstance(value, bool) or not isinstance(value, (int, float)) \
                or not math.isfinite(_as_float(value)):
            raise ProblemError(f"{self.source}: {key} must be a number in (0, 1) "
                               f"(got {shown(value)})")
        if not 0.0 < value < 1.0:
            raise ProblemError(f"{self.source}: {key} must lie in (0, 1) (got {value:g})")
        if self.operating_speed is not None and \
                self.operating_speed > value * self.critical_speed:
            raise ProblemError(
                f"{self.source}: {key} = {value:g} allows at most "
                f"{value * self.critical_speed:.6g} rad/s, below driveline.operating_speed_rad_s "
                f"= {self.operating_speed:g}, whatever the design")

    def speed_curves(self, upper_fraction: float = 0.95, n: int = 400) -> dict:
        """y_max (eqs. 14, 18) and D0 (eq. 15) from rest to ``upper_fraction``·ω_cr, for plots."""
        w_cr = self.critical_speed
        omega = np.linspace(0.0, upper_fraction * w_cr, n)
        args = (w_cr, self.mass, self.EI, self.y0_max, self.length, self.A, self.C)
        y = model.deflection(omega, w_cr, self.y0_max)
        dk1, dk2 = model.corrections_balanced_at(omega, *args)
        return {"omega_rad_s": omega, "y_max_mm": y * 1e3,
                "D0_g_mm": model.principal_imbalance(self.mass, y) * G_MM_PER_KG_M,
                "y_max_balanced_mm": model.deflection_balanced_at(omega, *args) * 1e3,
                "Dk1_g_mm": dk1 * G_MM_PER_KG_M, "Dk2_g_mm": dk2 * G_MM_PER_KG_M,
                "critical_speed_rad_s": w_cr}


# --------------------------------------------------------------------------- parsing
def parse_section(raw, reader) -> DrivelineSection:
    """Read and check a ``driveline:`` mapping; ``reader`` names the file and ``driveline.``."""
    raw = reader.mapping(raw, "")
    reader.known_keys(raw, "", KEYS)

    def required(key):
        if key not in raw:
            raise reader.error(key, "is required")
        return reader.number(raw[key], key, positive=True)

    def optional(key, default, positive=True):
        return default if key not in raw else reader.number(raw[key], key, positive=positive)

    length = required("length_mm")
    planes = {}
    for key in ("A_mm", "C_mm"):
        if key not in raw:
            raise reader.error(key, "is required (correction plane from its support, mm)")
        planes[key] = reader.number(raw[key], key)
        if planes[key] < 0:
            raise reader.error(key, f"must not be negative (got {planes[key]:g})")
        if planes[key] >= 0.5 * length:
            raise reader.error(key, f"must be less than half of length_mm, {0.5 * length:g} "
                                    f"(got {planes[key]:g})")

    try:
        with np.errstate(all="ignore"):
            mass_per_length, EI = _read_stiffness(raw, reader)
            y0_max, y0_source = _read_straightness(raw, reader, length)
            _check_derived(reader, mass_per_length_kg_m=mass_per_length, EI_n_m2=EI,
                           mass_kg=mass_per_length * length * 1e-3, y0_max_mm=y0_max * 1e3,
                           EI_over_mass_per_length=EI / mass_per_length)
            w_cr = model.first_critical_speed(length * 1e-3, EI, mass_per_length)
            _check_derived(reader, critical_speed_rad_s=w_cr, beta_s2=1.0 / w_cr**2)
    except (OverflowError, ZeroDivisionError):
        raise reader.error("", "describes a shaft whose figures overflow double precision; "
                               "check the units") from None
    balancing = optional("balancing_speed_rad_s",
                         DECLARATION.key("balancing_speed_rad_s").default, positive=False)
    if balancing < 0:
        raise reader.error("balancing_speed_rad_s", f"must not be negative (got {balancing:g})")
    operating = optional("operating_speed_rad_s", None)
    for key, omega in (("balancing_speed_rad_s", balancing), ("operating_speed_rad_s", operating)):
        if omega is not None and omega >= w_cr:
            raise reader.error(key, f"must be below the first critical speed {w_cr:.6g} rad/s "
                                    f"(got {omega:g})")
    if "speed_factor" in raw and operating is not None:
        raise reader.error("speed_factor", "applies only when operating_speed_rad_s is not given")
    factor = optional("speed_factor", DECLARATION.key("speed_factor").default)
    return DrivelineSection(length=length * 1e-3, A=planes["A_mm"] * 1e-3,
                            C=planes["C_mm"] * 1e-3, mass_per_length=mass_per_length, EI=EI,
                            y0_max=y0_max, y0_source=y0_source, balancing_speed=balancing,
                            operating_speed=operating, speed_factor=factor, source=reader.where)


def _read_stiffness(raw, reader) -> tuple[float, float]:
    """m' (kg/m) and EI (N·m²): from the tube's size and material, or given directly."""
    tube = [k for k in TUBE_KEYS if k in raw]
    direct = [k for k in DIRECT_KEYS if k in raw]
    if tube and direct:
        raise reader.error(direct[0], f"cannot be given with {tube[0]}: give the tube "
                                      f"(outer_diameter_mm, wall_mm) or mass_per_length_kg_m "
                                      f"and EI_n_m2")
    if direct:
        for key in DIRECT_KEYS:
            if key not in raw:
                raise reader.error(key, f"is required with {direct[0]}")
        return (reader.number(raw["mass_per_length_kg_m"], "mass_per_length_kg_m", True),
                reader.number(raw["EI_n_m2"], "EI_n_m2", True))
    for key in ("outer_diameter_mm", "wall_mm"):
        if key not in raw:
            raise reader.error(key, "is required (or give mass_per_length_kg_m and EI_n_m2)")
    outer = reader.number(raw["outer_diameter_mm"], "outer_diameter_mm", positive=True)
    wall = reader.number(raw["wall_mm"], "wall_mm", positive=True)
    if wall > 0.5 * outer:
        raise reader.error("wall_mm", f"must not exceed half of outer_diameter_mm, {0.5 * outer:g}"
                                      f" (got {wall:g})")
    if wall < MIN_WALL_FRACTION * outer:
        raise reader.error("wall_mm", f"must be at least {MIN_WALL_FRACTION:g} of "
                                      f"outer_diameter_mm, {MIN_WALL_FRACTION * outer:g} "
                                      f"(got {wall:g})")
    E = reader.number(raw.get("youngs_modulus_gpa", STEEL_YOUNGS_MODULUS_GPA),
                      "youngs_modulus_gpa", positive=True)
    rho = reader.number(raw.get("density_kg_m3", STEEL_DENSITY_KG_M3), "density_kg_m3",
                        positive=True)
    area, second_moment = model.tube_section(outer * 1e-3, wall * 1e-3)
    return rho * area, E * 1e9 * second_moment


def _check_derived(reader, **figures) -> None:
    """Figures derived from the section's numbers must be finite and positive: extreme but
    accepted numbers (a tube a light-year wide) must not reach the model as 0 or inf."""
    for name, value in figures.items():
        if not (np.isfinite(value) and value > 0):
            raise reader.error("", f"describes a shaft whose {name} is {value:g}, not a "
                                   f"finite positive number; check the units")


def _read_straightness(raw, reader, length_mm) -> tuple[float, str]:
    """y0_max (m) and how it was set: GOST 5005-82 class (eq. 11) or given."""
    if "y0_max_mm" in raw and "straightness_class" in raw:
        raise reader.error("y0_max_mm", "cannot be given with straightness_class; give one")
    if "y0_max_mm" in raw:
        return reader.number(raw["y0_max_mm"], "y0_max_mm", positive=True) * 1e-3, "given"
    classes = model.GOST_5005_STRAIGHTNESS_MM_PER_M
    name = reader.choice(raw.get("straightness_class", DEFAULT_STRAIGHTNESS_CLASS),
                         "straightness_class", list(classes))
    per_metre = classes[name]
    return (model.initial_deflection(length_mm * 1e-3, per_metre),
            f"GOST 5005-82 {name}: {per_metre:g} mm/m")


def _as_float(value) -> float:
    """``value`` as a float, an integer too large for one as infinity."""
    try:
        return float(value)
    except OverflowError:
        return math.inf

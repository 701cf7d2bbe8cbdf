"""The unit of every key in the package's JSON documents, and the stamp each document carries.

Every JSON document the package writes or prints (``result.json``, ``pareto.json``,
``accuracy.json``, the ``--json`` prints of ``analyze``, ``solve``, ``driveline`` and
``bench``) holds, at its top level,

- ``schema_version``: :data:`optdesign.outputs.atomic.SCHEMA_VERSION`;
- ``units``: ``{key: unit}`` for every key of the document with a number (or a null where a
  number can stand) at any depth, a key meaning the same wherever it appears. A mapping whose
  numbers share one unit (``timings_s``) is named once and not entered.

A key's unit comes from, in this order: the mechanism's design variables (``l0: mm``,
``phases: -``), :data:`UNITS`, and the unit suffix of its name (:data:`SUFFIX_UNITS`:
``_mm``, ``_deg``, ``_rad_s``, ...). ``-`` is a dimensionless number or a count. A key of
unknown unit is left out: ``tests/test_units.py`` fails on it, so a new key is given a unit
before it is released.
"""
from __future__ import annotations

from collections.abc import Mapping
from numbers import Number

from optdesign.mechanisms import REGISTRY, get_mechanism
from optdesign.outputs.atomic import SCHEMA_VERSION
from optdesign.quantities import get_quantity, known

#: the ratio's convention, stated wherever a ratio is reported
RATIO_UNIT = ("- (output speed / input speed, omega_out/omega1; the gear-ratio convention "
              "i = n_in/n_out is its inverse, i = 1/ratio)")
RATIO_OF_SPEEDS = "- (a ratio: output speed / input speed)"
COUNT = "- (count)"
DESIGN_UNIT = "mm (lengths), - (counts)"

#: keys whose unit their name does not carry
UNITS: dict[str, str] = {
    # output speeds of one stroke (optdesign.envelope.sampled.StrokeFigures) and the crank
    "omega_max": "rad/s", "omega_min": "rad/s", "omega_mean": "rad/s (time mean)",
    "omega_midrange": "rad/s ((omega_max + omega_min)/2)",
    "omega_avg": "rad/s (deprecated alias of omega_midrange)",
    "input_speed": "rad/s (omega1, the crank)",
    "delta": "- (ripple, (omega_max - omega_min)/omega_midrange; a solve's or a front's by "
             "objective.ripple)",
    "delta_mean": "- ((omega_max - omega_min)/omega_mean)",
    "ratio": RATIO_UNIT,
    "min_ratio": RATIO_OF_SPEEDS, "max_ripple": "-", "ratio_lower": RATIO_OF_SPEEDS,
    "ratio_upper": RATIO_OF_SPEEDS,
    "eccentricity": "- (fraction of the regulated length)",
    "eccentricities": "- (fractions of the regulated length)",
    "eccentricity_range": "- (fractions of the regulated length: lower, upper)",
    "worst_eccentricity": "- (fraction of the regulated length where delta is largest over "
                          "the regulation interval)",
    "worst_case_delta": "- (the largest delta over the tolerance box: a robust solve's "
                        "objective)",
    "worst_case_min_transmission_angle_deg": "deg (the least over the tolerance box)",
    "angle_eccentricity": "- (fraction of the regulated length where the transmission angle "
                          "is least over the regulation interval)",
    # the design and the checks
    "design": DESIGN_UNIT, "start": DESIGN_UNIT,
    "chain": "- (chain number)",
    "margin": "the entry's unit (deg, mm or -)",
    "sensitivity": "objective per the entry's unit",
    # solve
    "count": "- (the design's count: phases, sections or freewheels)",
    "iterations": COUNT, "starts": COUNT, "surrogate_delta": "-",
    "surrogate_gap": "- (surrogate delta - exact delta)",
    "ratio_multiplier": "- (d delta / d ratio)",
    "timings": "s (per stage)", "timings_s": "s (per stage)",
    "designs": COUNT, "passed_filters": COUNT, "basins": COUNT, "polished": COUNT,
    "distinct_optima": COUNT,
    "critical_distance": "- (in the box scaled to [0, 1] per free length)",
    # sensitivities of an optimum (optdesign.evaluation.sensitivity): {length: derivative}
    "d_delta_d_length_per_mm": "1/mm (d delta / d length, per design length)",
    "d_ratio_d_length_per_mm": "1/mm (d ratio / d length at e = 1, per design length)",
    "d_transmission_angle_margin_d_length_deg_per_mm":
        "deg/mm (d (least transmission angle - min_transmission_angle_deg) / d length)",
    "nlp_samples": COUNT, "nlp_smoothing": "- (rho, per unit of omega/omega1)",
    "exact_grid": COUNT, "length_relative": "- (relative)",
    # tolerance (optdesign.tolerance): the Monte Carlo's distributions, one unit each
    "delta_distribution": "- (delta of the parts: mean, std, min, max, percentiles p1 .. p99)",
    "ratio_distribution": RATIO_OF_SPEEDS + " (of the parts: mean, std, min, max, percentiles)",
    "mu_min_deg_distribution": "deg (least transmission angle of the parts: mean, std, min, "
                               "max, percentiles)",
    "nominal_delta": "- (delta of the nominal design)", "exact_evaluations": COUNT,
    "parts": COUNT, "crank_samples": COUNT, "k": "- (sigma = tolerance / k)",
    "seed": "- (seed of the sample)",
    "share_not_assembling": "- (share of the parts)",
    "share_below_min_transmission_angle": "- (share of the parts)",
    "share_below_min_ratio": "- (share of the parts)",
    "share_above_max_ripple": "- (share of the parts)",
    "share_rejected": "- (share of the parts: not assembling or below the angle)",
    "share_outside_bounds": "- (share of the parts beyond each side of a bound, by its file "
                            "key)",
    "share_failing_any": "- (share of the parts: not assembling, or beyond any rule the "
                         "parts' figures give)",
    # pareto
    "epsilon": RATIO_OF_SPEEDS + ", the ratio bound of the point's solve",
    "hypervolume": "- (normalised objectives)", "spacing": "- (normalised objectives)",
    "reference_point_normalised": "- (normalised objectives)",
    "knee": "- (row index)", "index": "- (row index)", "key": "- (phase count, point index)",
    "n_points": COUNT, "knee_at_rest_excluded": COUNT,
    "points": COUNT, "counts": "- (phase counts)", "tries": COUNT,
    "resumed_points": COUNT, "workers": COUNT,
    "round": "- (refinement round; 0: the uniform pass, 5 and later: the hypervolume "
             "rounds)", "merged": COUNT,
    "max_gap": "- (normalised objectives)", "max_points": COUNT,
    "hypervolume_gap": "- (normalised objective area)", "hypervolume_points": COUNT,
    "delta_resolution": "- (pareto.resolution.delta: no point between neighbours closer in "
                        "delta and the gain)",
    "gain_resolution": "the unit of the ratio or of the quantity swept against "
                       "(pareto.resolution; null: 1e-3 of its value)",
    # bench accuracy
    "samples": COUNT, "smoothing": "- (rho, per unit of omega/omega1)",
    "delta_error": "- (absolute)", "delta_signed": "- (delta - reference delta)",
    "ratio_error": "- (absolute)", "omega_min_error": "- (relative to the reference)",
    "reference_delta": "-", "sampled_minus_exact_delta": "-",
    # driveline (the rest carry their unit in the name)
    "amplification": "- (y_max / y0_max)", "b": "-", "max_speed_fraction_of_critical": "-",
    "speed_fraction_of_critical": "- (operating speed / critical speed)",
    # dynamics
    "omega_in_mean": "rad/s", "omega_out_mean": "rad/s", "omega_out_max": "rad/s",
    "omega_out_min": "rad/s", "delta_dynamic": "-", "delta_mean_dynamic": "-",
    "delta_kinematic": "-", "delta_mean_kinematic": "-", "eps": "rad", "eps_max": "rad",
    "power_balance": "- ((P_in - P_out)/P_in)", "steady_residual": "- (relative)",
    "engaged_share": "- (share of the cycle's time)",
    "rtol": "-", "atol": "rad", "cycles": COUNT, "period_turns": COUNT, "steps": COUNT,
    "events": COUNT, "counters": "- (counts)",
    "pulses_per_turn": COUNT, "harmonic": "- (k of the k-th pulse harmonic)",
    "relative_gap": "- (|harmonic / natural frequency - 1|)",
    "delta_ratio": "- (dynamic delta / kinematic delta)",
}

#: a key ending so has this unit (longest suffix first)
SUFFIX_UNITS: dict[str, str] = {
    "_g_mm": "g*mm", "_rad_s": "rad/s", "_kg_m3": "kg/m^3",
    "_kg_m": "kg/m", "_n_m2": "N*m^2", "_gpa": "GPa", "_rpm": "rpm", "_deg": "deg",
    "_mm": "mm", "_kg": "kg", "_s2": "s^2", "_w": "W", "_rad": "rad", "_s": "s",
    "_n_m": "N*m", "_n": "N",
}

#: mappings whose numbers share one unit: named once, not entered
OPAQUE = frozenset({"timings", "timings_s", "counters", "delta_distribution",
                    "ratio_distribution", "mu_min_deg_distribution", "d_delta_d_length_per_mm",
                    "d_ratio_d_length_per_mm",
                    "d_transmission_angle_margin_d_length_deg_per_mm"})


def unit_of(key: str, variables: Mapping[str, str] | None = None) -> str | None:
    """The unit of ``key``, or None when neither the variables, :data:`UNITS` nor its
    suffix give one."""
    if variables and key in variables:
        return variables[key]
    if key in UNITS:
        return UNITS[key]
    quantity = _quantity_units().get(key)
    if quantity is not None:
        return quantity
    for suffix, unit in sorted(SUFFIX_UNITS.items(), key=lambda s: -len(s[0])):
        if key.endswith(suffix):
            return unit
    return None


def _quantity_units() -> dict[str, str]:
    """The unit of every quantity by name (:mod:`optdesign.quantities`), the ratio's with its
    convention."""
    return {name: get_quantity(name).unit for name in known()} | {"ratio": RATIO_UNIT}


def units_of(document, variables: Mapping[str, str] | None = None) -> dict[str, str]:
    """``{key: unit}`` for every key of ``document`` with a known unit that holds a figure
    (:func:`_holds_a_figure`) anywhere in it, sorted by key."""
    found: dict[str, str] = {}

    def walk(value, key):
        if isinstance(key, str) and _holds_a_figure(key, value):
            unit = unit_of(key, variables)
            if unit is not None:
                found[key] = unit
        if isinstance(value, Mapping) and key not in OPAQUE:
            for k, v in value.items():
                walk(v, k)
        elif isinstance(value, (list, tuple)):
            for v in value:
                walk(v, key)

    walk(document, None)
    return dict(sorted(found.items()))


def _number(value) -> bool:
    return isinstance(value, Number) and not isinstance(value, bool)


def _holds_a_figure(key: str, value) -> bool:
    """A number, a null, a list holding a number, or a mapping :data:`UNITS` names."""
    if value is None or _number(value):
        return True
    if isinstance(value, (list, tuple)):
        return any(_number(v) for v in value)
    return isinstance(value, Mapping) and key in UNITS


def design_units(mechanism: str) -> dict[str, str]:
    """``{design key: unit}`` of a registered mechanism (empty for an unknown name)."""
    if mechanism not in REGISTRY:
        return {}
    return {v.name: v.unit for v in get_mechanism(mechanism).variables}


def stamped(document: dict, variables: Mapping[str, str] | None = None) -> dict:
    """``document`` with ``schema_version`` and its ``units`` block added at the end."""
    out = {k: v for k, v in document.items() if k not in ("schema_version", "units")}
    return out | {"schema_version": SCHEMA_VERSION, "units": units_of(out, variables)}


def gear_ratio_text(ratio, digits: int = 4) -> str:
    """The gear ratio i = n_in/n_out = 1/ratio as text for the terminal: "inf" for an output
    at rest, "-" when there is no ratio."""
    if ratio is None or ratio != ratio:
        return "-"
    return "inf" if ratio <= 0 else f"{1.0 / ratio:.{digits}f}"


def input_speed_text(omega: float) -> str:
    """The crank speed ω1 in rad/s and in rpm, "ω1 = 15.18 rad/s (145 rpm)": what every
    command's first line states, so that a speed given in rpm shows at once."""
    return f"ω1 = {omega:g} rad/s ({omega * 30 / 3.141592653589793:.4g} rpm)"

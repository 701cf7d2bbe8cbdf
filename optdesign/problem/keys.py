"""Every key of a problem file for one mechanism, as one tree of declarations.

The tree is assembled from what the loader itself reads: the tables of
:mod:`optdesign.problem.loader` (top level, objective, regulation, solver, constraints), the
mechanism's ``variables``, ``options``, ``strokes`` and ``constraint_declarations``, and the
``DECLARATION`` of each section module registered in ``SECTION_PARSERS``. The generated
reference (docs/problem-file.md), the JSON Schema and ``optdesign init`` are written from it.
"""
from __future__ import annotations

import json
from dataclasses import replace
from importlib import import_module

import yaml

from optdesign.declarations import Key, REQUIRED
from optdesign.mechanisms import get_mechanism
from optdesign.problem.loader import (CONSTRAINT_KEYS, EXTRA_CONSTRAINT_KEYS,
                                      GENERAL_CONSTRAINT_KEYS, MAX_COUNT, OBJECTIVE_KEYS,
                                      REGULATION_KEYS, SECTION_PARSERS, SOLVER_KEYS,
                                      TOP_DECLARATIONS)
from optdesign.quantities import known as known_quantities


def design_keys(mech) -> tuple[Key, ...]:
    """The mechanism's design keys: its lengths (a number, or a free range) and its count."""
    out = []
    for spec in mech.variables:
        if spec.integer:
            out.append(Key(spec.name, "count", spec.meaning, unit=spec.unit, default=REQUIRED,
                           lower=spec.minimum, upper=MAX_COUNT))
        else:
            out.append(Key(spec.name, "length", spec.meaning, unit=spec.unit, default=REQUIRED,
                           lower=spec.minimum, open_lower=True))
    return tuple(out)


def option_keys(mech) -> tuple[Key, ...]:
    """The mechanism's ``options:`` (its OptionSpecs)."""
    return tuple(Key(o.name, "choice", o.meaning, default=o.default, choices=tuple(o.choices))
                 for o in mech.options)


def constraint_keys(mech) -> tuple[Key, ...]:
    """The ``constraints:`` keys a file with this mechanism may give: the general ones, the
    mechanism's own (its ``constraint_declarations``), those of the sections and a bound per
    quantity."""
    accepted = GENERAL_CONSTRAINT_KEYS | EXTRA_CONSTRAINT_KEYS | set(known_quantities())
    missing = accepted - {k.name for k in CONSTRAINT_KEYS}
    if missing:
        raise LookupError(f"constraint keys {sorted(missing)} are not declared in "
                          f"optdesign.problem.loader.CONSTRAINT_KEYS")
    general = [k for k in CONSTRAINT_KEYS if k.name in GENERAL_CONSTRAINT_KEYS]
    rest = [k for k in CONSTRAINT_KEYS if k.name in accepted - GENERAL_CONSTRAINT_KEYS]
    return tuple(general) + tuple(mech.constraint_declarations) + tuple(rest)


def section_keys() -> tuple[Key, ...]:
    """The optional sections (``driveline:`` ...), each its module's ``DECLARATION``; a
    section that declares nothing takes any value here (its parser still checks it)."""
    out = []
    for name, target in SECTION_PARSERS.items():
        module = import_module(target.split(":")[0])
        declared = getattr(module, "DECLARATION", None)
        out.append(declared if declared is not None else
                   Key(name, "either", f"parsed by {target}; its keys are not declared"))
    return tuple(out)


def problem_keys(mechanism: str) -> tuple[Key, ...]:
    """Every key of a problem file for ``mechanism``, top level first, then the sections."""
    mech = get_mechanism(mechanism)
    nested = {"stroke": {"choices": tuple(mech.strokes)},
              "design": {"keys": design_keys(mech)},
              "options": {"keys": option_keys(mech)},
              "constraints": {"keys": constraint_keys(mech)},
              "objective": {"keys": OBJECTIVE_KEYS},
              "regulation": {"keys": REGULATION_KEYS},
              "solver": {"keys": SOLVER_KEYS}}
    top = tuple(replace(k, **nested.get(k.name, {})) for k in TOP_DECLARATIONS)
    return top + section_keys()


def walk(keys, prefix: str = ""):
    """``(path, key)`` of every key and nested key of a mapping, depth first; the tables of
    an ``either`` key's mapping alternatives are walked too."""
    for key in keys:
        path = f"{prefix}{key.name}"
        yield path, key
        yield from walk(key.keys, path + ".")
        for alt in key.alternatives:
            yield from walk(alt.keys, path + ".")


# --------------------------------------------------------------------------- values as YAML
def flow(value) -> str:
    """``value`` as YAML flow text that any YAML reader reads back as the same value (a float
    keeps its point: 1.0e-08, not 1e-08, which YAML 1.1 reads as text)."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        text = repr(value)
        mantissa, _, exponent = text.partition("e")
        if exponent and "." not in mantissa:
            text = f"{mantissa}.0e{exponent}"
        return text
    if isinstance(value, str):
        plain = value and not any(c in value for c in ":#{}[],&*!|>'\"%@`") and \
            value == value.strip() and yaml.safe_load(value) == value
        return value if plain else json.dumps(value, ensure_ascii=False)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(flow(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k}: {flow(v)}" for k, v in value.items()) + "}"
    raise TypeError(f"no YAML text for {type(value).__name__}")

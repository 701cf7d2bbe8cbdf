"""A JSON Schema (draft 2020-12) of the problem file, from the loader's declarations.

``optdesign schema`` prints it, for editors that complete and check YAML against a schema
and for other tools. It says what the declarations say (types, ranges, choices, required and
unknown keys, the keys of each mechanism); the loader checks more (a length shorter than
another, ``lower`` not above ``upper``, the driveline's planes inside half its length), so a
file the schema accepts can still be refused, one line naming the key, by ``optdesign
analyze``.
"""
from __future__ import annotations

from optdesign.declarations import Key, REQUIRED
from optdesign.mechanisms import get_mechanism, known
from optdesign.problem.keys import problem_keys
from optdesign.problem.loader import MAX_INTEGER, MAX_TEXT_CHARS, NUMBER_MAGNITUDE
from optdesign.quantities.bounds import ALIASES
from optdesign.quantities.criteria import objectives

DIALECT = "https://json-schema.org/draft/2020-12/schema"
#: keys whose allowed values depend on the mechanism: stated once per mechanism
PER_MECHANISM = ("stroke", "design", "options", "constraints")


def problem_schema() -> dict:
    """The schema of a problem file for any registered mechanism: the keys common to all at
    the top, and per mechanism (``if mechanism is X then ...``) its strokes, design keys,
    options and constraint keys."""
    names = known()
    first = problem_keys(names[0])
    properties = {}
    for key in first:
        properties[key.name] = ({"description": _description(key)} if key.name in PER_MECHANISM
                                else key_schema(key))
    schema = {"$schema": DIALECT,
              "title": "optdesign problem file",
              "description": "What is optimised: the mechanism, its design keys (fixed or "
                             "free), constraints, objective and settings (docs/problem-file.md)",
              "type": "object",
              "properties": properties,
              "required": [k.name for k in first if k.required],
              "additionalProperties": False,
              "allOf": [_mechanism_rule(name) for name in names] + _objective_rules(first)}
    return schema


def _mechanism_rule(name: str) -> dict:
    keys = {k.name: k for k in problem_keys(name)}
    return {"if": {"properties": {"mechanism": {"const": name}}, "required": ["mechanism"]},
            "then": {"properties": {k: key_schema(keys[k]) for k in PER_MECHANISM},
                     "description": get_mechanism(name).source}}


def _objective_rules(keys) -> list[dict]:
    """``objective.max_ripple`` (and whatever else an objective ``requires``), or the
    ``constraints:`` bound that stands for it (``ripple: {upper}``), when
    ``objective.minimize`` names that objective."""
    out = []
    for name, objective in objectives().items():
        for key in objective.requires:
            ways = [{"properties": {"objective": {"required": [key]}},
                     "required": ["objective"]}]
            ways += [{"properties": {"constraints": {"properties": {quantity: {
                "required": [side]}}, "required": [quantity]}}, "required": ["constraints"]}
                for (quantity, side), target in ALIASES.items() if target == ("objective", key)]
            out.append({"if": {"properties": {"objective": {
                "properties": {"minimize": {"const": name}}, "required": ["minimize"]}},
                "required": ["objective"]},
                "then": ways[0] if len(ways) == 1 else {"anyOf": ways}})
    return out


def key_schema(key: Key) -> dict:
    """The schema of one key's value."""
    out = _value_schema(key)
    out["description"] = _description(key)
    if key.default not in (None, REQUIRED):
        out["default"] = key.default
    if key.nullable:
        out = {"anyOf": [out, {"type": "null"}], "description": out["description"]}
    return out


def _value_schema(key: Key) -> dict:
    low, high = NUMBER_MAGNITUDE
    kind = key.kind
    if kind == "number":
        out = {"type": "number"}
        if key.lower is None:
            out["minimum"] = -high
        elif key.lower == 0 and key.open_lower:
            out["minimum"] = low         # positive, and no denormal: the loader's limit
        else:
            out["exclusiveMinimum" if key.open_lower else "minimum"] = key.lower
        if key.upper is None:
            out["maximum"] = high
        else:
            out["exclusiveMaximum" if key.open_upper else "maximum"] = key.upper
        return out
    if kind == "integer":
        return {"type": "integer", "minimum": int(key.lower if key.lower is not None else 0),
                "maximum": int(key.upper if key.upper is not None else MAX_INTEGER)}
    if kind == "text":
        return {"type": "string", "minLength": 1,
                "maxLength": int(key.upper if key.upper is not None else MAX_TEXT_CHARS)}
    if kind == "choice":
        return {"enum": list(key.allowed())}
    if kind == "bool":
        return {"type": "boolean"}
    if kind == "list":
        out = {"type": "array", "items": key_schema(key.item), "minItems": key.min_items}
        if key.max_items is not None:
            out["maxItems"] = key.max_items
        return out
    if kind == "mapping":
        return {"type": "object", "properties": {k.name: key_schema(k) for k in key.keys},
                "required": [k.name for k in key.keys if k.required and not k.condition],
                "additionalProperties": False}
    if kind == "either":
        return {"anyOf": [key_schema(a) for a in key.alternatives]} if key.alternatives else {}
    if kind == "length":
        return _length_schema(key)
    if kind == "count":
        return _count_schema(key)
    raise ValueError(f"no schema for kind {kind!r}")


def _length_schema(key: Key) -> dict:
    value = _value_schema(Key(key.name, "number", key.meaning, lower=0, open_lower=True))
    bounds = {b: value for b in ("lower", "upper", "initial")}
    return {"anyOf": [value, {"type": "object", "properties": bounds,
                              "required": ["lower", "upper"], "additionalProperties": False}]}


def _count_schema(key: Key) -> dict:
    value = {"type": "integer", "minimum": int(key.lower), "maximum": int(key.upper)}
    return {"anyOf": [
        value,
        {"type": "object", "properties": {"lower": value, "upper": value},
         "required": ["lower", "upper"], "additionalProperties": False},
        {"type": "object", "properties": {"choices": {"type": "array", "items": value,
                                                       "minItems": 1}},
         "required": ["choices"], "additionalProperties": False}]}


def _description(key: Key) -> str:
    unit = f" [{key.unit}]" if key.unit and key.unit != "-" else ""
    extra = f" ({key.condition})" if key.condition else ""
    default = f"; default: {key.default_text}" if key.default is None and key.default_text \
        else ""
    return f"{key.meaning}{unit}{extra}{default}"

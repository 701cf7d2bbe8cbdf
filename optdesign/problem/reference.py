"""docs/problem-file.md: every key of a problem file, generated from the loader's declarations.

``reference_markdown()`` writes the page from the same tables the loader checks values
against (:mod:`optdesign.problem.keys`), with a complete starting file per mechanism (what
``optdesign init`` writes). Regenerate the committed page with::

    optdesign schema --markdown > docs/problem-file.md     # or: python -m optdesign.problem.reference

``tests/test_reference.py`` fails when the page and the code differ.
"""
from __future__ import annotations

from optdesign.declarations import Key, REQUIRED
from optdesign.mechanisms import get_mechanism, known
from optdesign.problem.keys import flow, problem_keys, section_keys
from optdesign.problem.loader import (MAX_COUNT, MAX_INTEGER, MAX_NAME_CHARS, MAX_TEXT_CHARS,
                                      MIN_REGULATED_FRACTION, NUMBER_MAGNITUDE, TOP_DECLARATIONS)
from optdesign.problem.starter import NoStarter, starter_text

REGENERATE = "optdesign schema --markdown > docs/problem-file.md"

SECTIONS_IN_ORDER = ("objective", "regulation", "solver")


def reference_markdown() -> str:
    """The text of docs/problem-file.md."""
    names = known()
    by_name = {k.name: k for k in problem_keys(names[0])}
    sections = section_keys()
    parts = [_intro(), _fixed_or_free(), _limits(names),
             "## Top level\n\nThe keys `stroke`, `design`, `options` and `constraints` take "
             "what the mechanism declares: see [Mechanisms](#mechanisms).\n\n"
             + _table(TOP_DECLARATIONS + sections, nested=False)]
    for name in SECTIONS_IN_ORDER:
        parts.append(_section(by_name[name]))
    parts.append(_constraints(names))
    parts += [_section(key, optional=True) for key in sections]
    parts.append("## Mechanisms\n\nThe design keys, options and constraint keys of each "
                 "mechanism, and a complete starting file: what `optdesign init --mechanism "
                 "NAME` writes (every optional key commented out at its default).")
    parts += [_mechanism(name) for name in names]
    return "\n\n".join(p.rstrip("\n") for p in parts) + "\n"


def _section(key: Key, optional: bool = False) -> str:
    """A ``name:`` section's heading, what it is, and its table."""
    required = [k.name for k in key.keys if k.required and not k.condition]
    needs = (f"Required keys: {', '.join(f'`{k}`' for k in required)}." if required else
             "Every key optional.")
    built = " Read only when the file has the section." if optional else ""
    head = f"## `{key.name}:`\n\n{key.meaning[0].upper()}{key.meaning[1:]}.{built}"
    if key.kind != "mapping":                   # a section that declares nothing
        return head
    return f"{head} {needs}\n\n" + _table(key.keys)


def _intro() -> str:
    return f"""# The problem file: every key

<!-- Generated from the loader's own declarations by optdesign/problem/reference.py; do not edit.
Regenerate: {REGENERATE} -->

A problem file is YAML: the mechanism, its design keys (each fixed or free), the constraints,
the objective and the solver's settings; nothing in it says how the results are drawn. Start
one with `optdesign init --mechanism NAME --out FILE`, check it with `optdesign analyze FILE`.
`optdesign schema` prints the same keys as a JSON Schema (draft 2020-12) for editors and other
tools. The commands, their JSON and exit codes: [contract.md](contract.md).

Every table below is generated from the tables the loader checks values against (the
defaults are the loader's own), so this page cannot say a default or a range the loader does
not apply. An unknown key anywhere is refused, naming the nearest known one."""


def _fixed_or_free() -> str:
    return """## Fixed or free

A design key is fixed by a number and freed by a range; the solve optimises the free ones.

| write | means |
|---|---|
| `l2: 225` | fixed at 225 mm |
| `l2: {lower: 100, upper: 400, initial: 225}` | free in [100, 400]; `analyze` uses `initial` |
| `l2: {lower: 100, upper: 400}` | free; `initial` is optional (default: the middle, 250) |
| `l2: {lower: 225, upper: 225}` | fixed: a collapsed range |
| `phases: 6` | one count |
| `phases: {lower: 4, upper: 8}` | every count from 4 to 8: one solve each, every count reported |
| `phases: {choices: [4, 6, 8]}` | these counts only |

The count (`phases`, `sections`, `freewheels`) is an integer: never `initial`. A list is not a
range: `l0: [100, 400]` is refused with the fix in the message,
`design.l0 must be a number or a range {lower, upper, initial} (got a list [100, 400]); to free
it write l0: {lower: 100, upper: 400}`."""


def _limits(names) -> str:
    low, high = NUMBER_MAGNITUDE
    regulated = ", ".join(f"`{get_mechanism(n).regulating_variable}`" for n in names)
    return (f"## Numbers and texts\n\n"
            f"- Every number is finite and, unless 0, of a magnitude between {low:g} and "
            f"{high:g}; `1e3` is a number.\n"
            f"- `name`: 1 to {MAX_NAME_CHARS} printable characters; any other text: at most "
            f"{MAX_TEXT_CHARS} characters.\n"
            f"- An integer with no limit of its own: at most {MAX_INTEGER}; a count: at most "
            f"{MAX_COUNT}.\n"
            f"- The regulated length ({regulated}) times the least eccentricity: at least "
            f"{MIN_REGULATED_FRACTION:g} of the longest length.\n"
            f"- The file: at most 1 MiB of UTF-8, nested at most 16 levels, no key twice in "
            f"one mapping ([contract.md](contract.md), \"Limits\").")


def _constraints(names) -> str:
    keys: dict[str, Key] = {}
    owners: dict[str, list[str]] = {}
    for name in names:
        for key in {k.name: k for k in problem_keys(name)}["constraints"].keys:
            keys[key.name] = key
            owners.setdefault(key.name, []).append(name)
    def mechanisms(k) -> str:          # a nested key (a bound's lower) belongs to its parent
        if k.name not in owners:
            return ""
        return ", ".join(f"`{m}`" for m in owners[k.name]) \
            if len(owners[k.name]) < len(names) else "every"

    table = _table(list(keys.values()), extra=("mechanisms", mechanisms))
    return ("## `constraints:`\n\nThe design's constraints, held at every listed eccentricity "
            "by the solve and checked exactly by `analyze`; every key optional. A key the "
            "file's mechanism does not declare is refused.\n\n" + table)


def _mechanism(name: str) -> str:
    mech = get_mechanism(name)
    keys = {k.name: k for k in problem_keys(name)}
    text = [f"### `{name}`", f"{mech.source}. Strokes: {', '.join(mech.strokes)}. The "
            f"regulated length, scaled by each eccentricity: `{mech.regulating_variable}`; "
            f"the count: `{mech.count_variable}`.",
            "Design keys (all required):", _table(keys["design"].keys, default=False)]
    if keys["options"].keys:
        text += ["Options:", _table(keys["options"].keys)]
    else:
        text.append("No options.")
    text.append("Constraint keys: " + ", ".join(f"`{k.name}`" for k in
                                                keys["constraints"].keys) + ".")
    try:
        example = starter_text(name)
    except NoStarter:
        text.append(f"No starting file: {name} declares no `starter` design.")
    else:
        text += [f"A complete file (`optdesign init --mechanism {name}`):",
                 "```yaml\n" + example.rstrip("\n") + "\n```"]
    return "\n\n".join(text)


# --------------------------------------------------------------------------- tables
def _table(keys, nested: bool = True, default: bool = True, extra=None) -> str:
    """One row per key (and nested key, as ``motor.a``): key, type, default, unit, allowed,
    meaning."""
    head = ["key", "type"] + (["default"] if default else []) + ["unit", "allowed", "meaning"]
    if extra:
        head.append(extra[0])
    rows = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for path, key in _rows(keys, nested):
        cells = [f"`{path}`", type_text(key)]
        if default:
            cells.append(default_text(key))
        cells += [key.unit or "", _cell(key.range_text()), _cell(_meaning(key))]
        if extra:
            cells.append(extra[1](key))
        rows.append("| " + " | ".join(cells) + " |")
    return "\n".join(rows)


def _rows(keys, nested: bool, prefix: str = ""):
    for key in keys:
        path = prefix + key.name
        yield path, key
        if nested:
            yield from _rows(key.keys, nested, path + ".")
            for alt in key.alternatives:
                yield from _rows(alt.keys, nested, path + ".")


def type_text(key: Key) -> str:
    """The key's type in words."""
    kind = key.kind
    if kind == "list":
        return f"list of {type_text(key.item)}s"
    if kind == "either":
        return " or ".join(dict.fromkeys(type_text(a) for a in key.alternatives)) or "any"
    if kind == "length":
        return "number or `{lower, upper, initial}`"
    if kind == "count":
        return "integer, `{lower, upper}` or `{choices: [...]}`"
    return {"bool": "true/false", "choice": "text"}.get(kind, kind)


def default_text(key: Key) -> str:
    """The default in words: a value, *required*, or what absence means."""
    if key.default is REQUIRED:
        return "required" + (f" {key.condition}" if key.condition else "")
    if key.default is None:
        return key.default_text or "none"
    return f"`{flow(key.default)}`"


def _meaning(key: Key) -> str:
    condition = f" ({key.condition})" if key.condition and key.default is not REQUIRED else ""
    return key.meaning + condition


def _cell(text: str) -> str:
    """Text safe inside a Markdown table cell."""
    return text.replace("|", "\\|")


if __name__ == "__main__":
    print(reference_markdown(), end="")

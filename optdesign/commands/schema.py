"""``optdesign schema [--markdown]``: the problem file's JSON Schema, or its reference page."""
from __future__ import annotations


def add_parser(sub) -> None:
    p = sub.add_parser("schema", help="print the problem file's JSON Schema (draft 2020-12), "
                                      "built from the loader's own declarations")
    p.add_argument("--markdown", action="store_true",
                   help="print the reference page instead (docs/problem-file.md)")
    p.set_defaults(run=run)


def run(args) -> int:
    if args.markdown:
        from optdesign.problem.reference import reference_markdown
        print(reference_markdown(), end="")
    else:
        from optdesign.outputs.atomic import json_text
        from optdesign.problem.schema import problem_schema
        print(json_text(problem_schema()))
    return 0

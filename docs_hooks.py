"""MkDocs hook (mkdocs.yml ``hooks:``): the site's pages may show and link to files of the
repository outside docs/.

- The home page, docs/index.md, is the README: one text for both, its links (written from the
  repository's root, ``docs/api.md``) made relative to docs/ (``api.md``).
- A page links to a results file or a figure outside docs/ the way GitHub shows it, relative to
  itself (``../benchmarks/results/atlas_fourbar/atlas_map.png``). MkDocs serves only docs/, so
  every such file is added to the site under ``repository/`` and the link pointed there.

A target that does not exist is left as written, and the strict build reports it like any
broken link.
"""
from __future__ import annotations

import posixpath
import re
from pathlib import Path

from mkdocs.structure.files import File, Files

ROOT = Path(__file__).resolve().parent
DOCS = "docs"
HOME = "index.md"
README = ROOT / "README.md"
PREFIX = "repository"
#: a Markdown link or image target: ](target), ](target#anchor) or ](target "title")
LINK = re.compile(r"\]\((?P<target>[^)\s#]+)(?P<rest>[^)]*)\)")


def _external(target: str) -> bool:
    return "://" in target or target.startswith(("#", "/", "mailto:"))


def _from_root(page_uri: str, target: str, base: str = DOCS) -> str:
    """A page's link target as a path from the repository's root (``base``: the folder the
    page's text was written in)."""
    return posixpath.normpath(posixpath.join(base, posixpath.dirname(page_uri), target))


def _outside(path: str) -> bool:
    """A repository file outside docs/."""
    return not path.startswith(DOCS + "/") and not path.startswith("../") \
        and (ROOT / path).is_file()


def _text(file: File) -> tuple[str, str]:
    """The Markdown a page shows and the folder its links are written from."""
    if file.src_uri == HOME:
        return README.read_text(encoding="utf-8"), "."
    return Path(file.abs_src_path).read_text(encoding="utf-8"), DOCS


def on_files(files: Files, config):
    wanted = set()
    for file in files.documentation_pages():
        text, base = _text(file)
        for m in LINK.finditer(text):
            if not _external(m["target"]):
                path = _from_root(file.src_uri if base == DOCS else "", m["target"], base)
                if _outside(path):
                    wanted.add(path)
    for path in sorted(wanted):
        uri = f"{PREFIX}/{path}"
        if files.get_file_from_path(uri) is None:
            files.append(File.generated(config, uri, abs_src_path=str(ROOT / path)))
    return files


def on_page_markdown(markdown: str, page, config, files):
    uri = page.file.src_uri
    base = DOCS
    if uri == HOME:
        # the README names a page by its path from the root ([docs/api.md](docs/api.md)); here
        # the path from docs/ is the name
        markdown = re.sub(r"\[docs/([^\]]+)\]\(docs/", r"[\1](docs/",
                          README.read_text(encoding="utf-8"))
        base = "."
    here = posixpath.join(DOCS, posixpath.dirname(uri))

    def repoint(m):
        if _external(m["target"]):
            return m[0]
        path = _from_root(uri if base == DOCS else "", m["target"], base)
        if path.startswith(DOCS + "/"):
            target = posixpath.relpath(path, here)
        elif _outside(path):
            target = posixpath.relpath(posixpath.join(DOCS, PREFIX, path), here)
        else:
            return m[0]
        return f"]({target}{m['rest']})"

    return LINK.sub(repoint, markdown)


#: a Sphinx role as a docstring writes it and Markdown renders it: :class:<code>~a.b.C</code>
ROLE = re.compile(r":(?:class|func|meth|attr|mod|data|obj|exc):<code>(?P<tilde>~?)"
                  r"(?P<name>[\w.]+)</code>")


def on_page_content(html: str, page, config, files):
    """The docstrings are numpydoc with Sphinx roles (``:class:`~optdesign.errors.ProblemError```),
    which Markdown shows as they are written. A role naming an object by its full path becomes a
    cross-reference (mkdocs-autorefs resolves it to the object's entry in the API reference, or
    leaves the name as code where the reference does not document it); a short name stays
    code. An rST literal-block colon pair ('imports::') is shown as one colon."""
    def role(m):
        name = m["name"]
        shown = f"<code>{name.rsplit('.', 1)[-1] if m['tilde'] else name}</code>"
        if name.startswith("optdesign."):
            return f'<autoref identifier="{name}" optional>{shown}</autoref>'
        return shown

    html = ROLE.sub(role, html)
    return re.sub(r"::</p>", ":</p>", html)

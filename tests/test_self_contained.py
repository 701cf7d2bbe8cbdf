"""The repository is self-contained: what a user reads never points at files they do not have.

README.md, docs/, problems/, optdesign/ and notebooks/ must not cite the team's working files
(the shared folder, its design notes, the seed copies of the papers) or tracker issue numbers.
The papers are cited by authors, title, year and equation number, with docs/papers.md for the
full citations and our readings; the formulation is docs/formulation.md, the file format and
commands docs/contract.md. The pattern is the review's grep, assembled from pieces so that this
file (which the review also greps) does not match it itself.
"""
from __future__ import annotations

import re
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CHECKED = ("README.md", "docs", "problems", "optdesign", "notebooks")
#: the review's grep -E pattern; issue numbers are matched in upper case too
FORBIDDEN = re.compile("|".join([re.escape("shared" + "/"), re.escape("DESIGN" + ".md"),
                                 re.escape("seeds" + "/"), r"\bissue[ -]?#?[0-9]"]),
                       re.IGNORECASE)
SKIPPED_DIRS = {"__pycache__", ".ipynb_checkpoints"}


def repository_files() -> list[Path]:
    """Files under CHECKED that git tracks or would add (untracked but not ignored); without
    git (e.g. an unpacked archive), every file under them."""
    try:
        out = subprocess.run(
            ["git", "ls-files", "--cached", "--others", "--exclude-standard", "-z", "--",
             *CHECKED], cwd=ROOT, capture_output=True, check=True).stdout
        names = [n for n in out.decode("utf-8").split("\0") if n]
        if names:
            return [ROOT / n for n in sorted(set(names))]
    except (OSError, subprocess.CalledProcessError):
        pass
    files = []
    for top in CHECKED:
        path = ROOT / top
        if path.is_file():
            files.append(path)
        elif path.is_dir():
            files += [p for p in path.rglob("*")
                      if p.is_file() and not SKIPPED_DIRS & set(p.relative_to(ROOT).parts)]
    return sorted(files)


def text_of(path: Path) -> str | None:
    """The file's text, or None for a binary file (grep -I skips those too)."""
    try:
        data = path.read_bytes()
    except OSError:              # listed by git but deleted in the work tree
        return None
    if b"\0" in data:
        return None
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        return None


def test_the_checked_paths_are_found():
    files = {p.relative_to(ROOT).as_posix() for p in repository_files()}
    assert "README.md" in files
    assert "docs/papers.md" in files and "docs/formulation.md" in files
    assert "docs/contract.md" in files
    assert any(f.startswith("optdesign/") and f.endswith(".py") for f in files)
    assert any(f.startswith("problems/") for f in files)


def test_no_reference_to_files_a_user_does_not_have():
    hits = []
    for path in repository_files():
        text = text_of(path)
        if text is None:
            continue
        for number, line in enumerate(text.splitlines(), 1):
            if FORBIDDEN.search(line):
                hits.append(f"{path.relative_to(ROOT).as_posix()}:{number}: {line.strip()}")
    assert not hits, ("cite the paper (authors, title, year, eq.) or docs/papers.md, "
                      "docs/formulation.md, docs/contract.md instead:\n" + "\n".join(hits))


def test_the_pattern_catches_what_it_should():
    slash, issue = "/", "issue"
    for bad in (f"see shared{slash}x", f"(seeds{slash}000_*)", "DESIGN" + ".md section 3",
                f"{issue} 5", f"{issue.title()} 3 target", f"{issue}-7", f"{issue} #4"):
        assert FORBIDDEN.search(bad), bad
    for good in ("Sharkov & Kalinin 2022, eq. (2)", "docs/formulation.md", "no. 2(46)",
                 "tissue", "the issue's target", "sharedness"):
        assert not FORBIDDEN.search(good), good

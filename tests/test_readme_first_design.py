"""The README's five-minute path, run as it is written: `optdesign init`, the two edited ranges,
`optdesign solve`, and the lines the README says it prints (about 3 s)."""
from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text(encoding="utf-8")


def _section() -> str:
    m = re.search(r"^## Five minutes to a first design\n(.*?)(?=^## )", README, re.S | re.M)
    assert m, "README has no 'Five minutes to a first design' section"
    return m.group(1)


def _edits(text: str) -> list[tuple[str, str]]:
    """The '| `old` | `new` |' rows of the section's table."""
    return re.findall(r"^\| `([^`]+)` \| `([^`]+)` \|$", text, re.M)


def _printed(text: str) -> list[str]:
    """The lines of the ```text block the README says solve prints, up to its '...'."""
    block = text.split("```text\n", 1)[1].split("```", 1)[0]
    return [ln for ln in block.splitlines() if ln and ln != "..."]


def _optdesign(*args, cwd) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "optdesign", *args], cwd=cwd,
                          capture_output=True, text=True, timeout=300,
                          env={"MPLBACKEND": "Agg", "PATH": "/usr/bin:/bin",
                               "PYTHONPATH": str(ROOT), "OPTDESIGN_SERVER": "off"})


def test_the_first_design_prints_what_the_readme_shows(tmp_path):
    text = _section()
    assert _optdesign("init", "--mechanism", "fourbar_converter", "--out", "my.yaml",
                      cwd=tmp_path).returncode == 0
    problem = tmp_path / "my.yaml"
    source = problem.read_text()
    edits = _edits(text)
    assert len(edits) == 2
    for old, new in edits:
        assert old in source, f"`optdesign init` no longer writes {old!r}"
        source = source.replace(old, new)
    problem.write_text(source)
    run = _optdesign("solve", "my.yaml", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    out = run.stdout.splitlines()
    # the first line now also gives ω1 in rpm, "ω1 = 97 rad/s (926.3 rpm)"; a README that
    # shows it without the rpm still shows what solve prints
    out += [re.sub(r" \([\d.]+ rpm\)", "", line) for line in out]
    shown = _printed(text)
    assert len(shown) >= 4
    for line in shown:
        assert line in out, f"README shows {line!r}; solve printed:\n{run.stdout}"

"""report.html of a small sweep rendered by headless Chromium: every embedded figure decodes and
the page is not blank.

Needs the Debian package ``chromium``; running as root with apt-get, the set-up installs it,
otherwise the test is skipped with the reason.
"""
import base64
import io
import os
import re
import shutil
import subprocess

import pytest

from optdesign.problem.loader import load_problem

FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync"]
#: written into a copy of the page: once loaded, the natural width of every image (-1 for one
#: not loaded), read back from the DOM Chromium dumps
PROBE = ('<script>window.addEventListener("load", function () {'
         'var w = [].map.call(document.images, function (i) {'
         'return i.complete ? i.naturalWidth : -1; });'
         'document.body.setAttribute("data-image-widths", w.join(",")); });</script>')


@pytest.fixture(scope="module")
def chromium():
    path = shutil.which("chromium") or ("/usr/bin/chromium"
                                        if os.path.exists("/usr/bin/chromium") else None)
    if path is None and hasattr(os, "geteuid") and os.geteuid() == 0 and \
            shutil.which("apt-get"):
        env = os.environ | {"DEBIAN_FRONTEND": "noninteractive"}
        for step in (["apt-get", "install", "-y", "chromium"],          # lists present
                     ["apt-get", "update"], ["apt-get", "install", "-y", "chromium"]):
            subprocess.run(step, capture_output=True, timeout=900, check=False, env=env)
            if shutil.which("chromium"):
                break
        path = shutil.which("chromium")
    if path is None:
        pytest.skip("headless Chromium not found: install the Debian package `chromium` "
                    "(apt-get install -y chromium, as root) to render report.html")
    return path


def _run(chromium, tmp_path, *args) -> str:
    cmd = [chromium, *FLAGS, f"--user-data-dir={tmp_path / 'profile'}", *args]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=60, check=False)
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout


@pytest.fixture(scope="module")
def report(small_front, small_path, tmp_path_factory):
    from optdesign.commands.files import write_report
    out = tmp_path_factory.mktemp("report")
    write_report(small_front[0], load_problem(small_path), out)
    return out / "report.html"


def test_every_embedded_figure_is_a_png_that_decodes(report):
    from PIL import Image

    sources = re.findall(r'<img alt="([^"]+)" src="data:image/png;base64,([^"]+)"',
                         report.read_text())
    assert [name for name, _ in sources] == ["fronts.png", "lengths.png",
                                             "knee_mechanism.png", "knee_speeds.png"]
    for name, data in sources:
        image = Image.open(io.BytesIO(base64.b64decode(data, validate=True)))
        image.load()
        assert image.format == "PNG" and min(image.size) > 200, name


def test_chromium_loads_every_image_and_draws_the_page(chromium, report, tmp_path):
    import numpy as np
    from PIL import Image

    probe = tmp_path / "probe.html"
    probe.write_text(report.read_text().replace("</body>", PROBE + "</body>"))
    dom = _run(chromium, tmp_path, "--virtual-time-budget=5000", "--dump-dom",
               probe.as_uri())
    widths = re.search(r'data-image-widths="([^"]*)"', dom)
    assert widths, "the page's load event never ran"
    widths = [int(w) for w in widths.group(1).split(",")]
    assert len(widths) == 4 and min(widths) > 200, widths
    shot = tmp_path / "shot.png"
    _run(chromium, tmp_path, f"--screenshot={shot}", "--window-size=1200,3000",
         report.as_uri())
    pixels = np.asarray(Image.open(shot).convert("L"))
    assert pixels.shape == (3000, 1200)
    # text, tables and figures: a good share of the page is not white, down the whole page
    assert (pixels < 200).mean() > 0.01
    rows = np.nonzero((pixels < 200).any(axis=1))[0]
    assert rows.max() - rows.min() > 2000

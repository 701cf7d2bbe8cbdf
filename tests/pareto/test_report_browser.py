"""report.html of a small sweep rendered by headless Chromium: every embedded figure decodes and
the page is not blank.

Needs the Debian package ``chromium``; running as root with apt-get, the set-up installs it,
otherwise the test is skipped with the reason.
"""
import base64
import io
import re

import pytest

from optdesign.problem.loader import load_problem
from tests.conftest import chromium_run as _run

#: written into a copy of the page: once loaded, the natural width of every image (-1 for one
#: not loaded), read back from the DOM Chromium dumps
PROBE = ('<script>window.addEventListener("load", function () {'
         'var w = [].map.call(document.images, function (i) {'
         'return i.complete ? i.naturalWidth : -1; });'
         'document.body.setAttribute("data-image-widths", w.join(",")); });</script>')


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

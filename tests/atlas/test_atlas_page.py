"""atlas.html in headless Chromium: self-contained (no address outside the page), a cell per
rectangle, and hovering a cell shows its design and draws its linkage."""
import re

from tests.conftest import chromium_run

#: hovers the last cell once the page has run its script
PROBE = """<script>
const rects = document.querySelectorAll("rect.cell");
rects[rects.length - 1].dispatchEvent(new MouseEvent("mouseenter"));
document.body.setAttribute("data-cells", String(rects.length));
</script>"""


def test_hovering_a_cell_shows_its_design_and_linkage(chromium, tiny_atlas, tmp_path):
    out, frame = tiny_atlas
    page = (out / "atlas.html").read_text()
    assert not re.search(r"(src|href)=\"(https?:)?//", page)          # nothing fetched
    probe = tmp_path / "probe.html"
    probe.write_text(page.replace("</body>", PROBE + "</body>"))
    dom = chromium_run(chromium, tmp_path, "--virtual-time-budget=3000", "--dump-dom",
                       probe.as_uri())
    assert 'data-cells="4"' in dom, "the page's script never ran"
    info = dom[dom.index('id="info"'):]
    assert "<h3>cell 3</h3>" in info and "optimal" in info
    delta = frame.loc[3, "delta"]
    assert f"{delta:.6f}" in info                                      # the cell's δ
    drawing = info[info.index('id="drawing"'):info.index("</svg>")]
    assert drawing.count("<line") >= 10 and drawing.count("<circle") >= 10

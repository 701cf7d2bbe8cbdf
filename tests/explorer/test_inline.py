"""The explorer shown in a notebook: its stylesheets made inline in one pass over the
document's models give the page Panel's own pass gives, in fewer collections of the graph."""
import re

import pytest

pn = pytest.importorskip("panel")

from optdesign.explorer import inline  # noqa: E402
from optdesign.explorer.page import Page  # noqa: E402
from optdesign.explorer.session import Session  # noqa: E402
from tests.conftest import ROOT  # noqa: E402

DISC = ROOT / "problems" / "sharkov2022_disc.yaml"
#: Bokeh's model ids and Panel's names of objects (numbered through the process: "p1150",
#: "Row00347"), the Python ids of linked objects, the display's UUIDs and its comms' ids
IDS = re.compile(r"\bp\d+\b|\b[A-Z][A-Za-z]*\d{5}\b|\b\d{12,}\b|\b[0-9a-f]{32}\b|"
                 r"[0-9a-f]{8}-[0-9a-f]{4}-[0-9a-f]{4}-[0-9a-f]{4}-[0-9a-f]{12}")


def _normalised(html: str) -> str:
    """``html`` with every id named by the order it first appears in."""
    names: dict = {}
    return IDS.sub(lambda m: names.setdefault(m.group(0), f"id{len(names)}"), html)


def _shown(monkeypatch, row) -> tuple:
    """The notebook's HTML of the explorer's page laid out in ``row``, and how many times
    Bokeh collected a document's models as it was shown."""
    from bokeh.document.models import DocumentModelManager

    monkeypatch.setattr(inline, "InlineRow", row)
    pn.extension(inline=True)
    layout = Page(Session.open(DISC), None, wide=False).layout
    assert type(layout) is row
    collected = []
    recompute = DocumentModelManager.recompute
    monkeypatch.setattr(DocumentModelManager, "recompute",
                        lambda self: (collected.append(1), recompute(self))[1])
    bundle, _ = layout._repr_mimebundle_()
    monkeypatch.undo()
    return _normalised(bundle["text/html"]), len(collected)


def test_the_page_shown_inline_in_one_pass_is_the_page_panel_shows(monkeypatch):
    pn.extension(inline=True)
    pn.Row(pn.pane.HTML("x"))._repr_mimebundle_()  # the process's first display adds a Location
    ours, ours_collected = _shown(monkeypatch, inline.InlineRow)
    panels, panels_collected = _shown(monkeypatch, pn.Row)
    assert "InlineStyleSheet" in ours and "ImportedStyleSheet" not in ours
    assert ours == panels
    assert ours_collected * 3 < panels_collected, (ours_collected, panels_collected)

"""The explorer's page without a browser: what a redraw sends the page (the browser test
drives the whole page through a real server)."""
import numpy as np
import pytest

pytest.importorskip("panel")

from optdesign.explorer.page import Page, _drawn, _shown  # noqa: E402
from optdesign.explorer.session import Session  # noqa: E402
from tests.conftest import ROOT  # noqa: E402

DISC = ROOT / "problems" / "sharkov2022_disc.yaml"


def _sent(page, move) -> list:
    """The changes a redraw after ``move(session)`` sends the page: (model name, attribute,
    columns)."""
    from bokeh.document import Document

    doc = Document()
    doc.add_root(page.layout.get_root(doc))
    events = []
    doc.callbacks.on_change(events.append)
    move(page.session)
    page.refresh()
    return [(getattr(e.model, "name", None), e.attr, sorted(getattr(e, "cols", None) or []))
            for e in events]


def test_a_move_sends_only_what_changed():
    page = Page(Session.open(DISC))
    sent = _sent(page, lambda s: s.set("l3", 57))
    assert ("explore-members", "data", ["ys"]) in sent          # not the crank angles
    assert ("explore-outputs", "data", ["label", "ys"]) in sent
    assert ("explore-paths", "data", ["x", "y"]) in sent
    assert ("explore-links", "data", ["x0", "x1", "y0", "y1"]) in sent
    assert ("explore-joints", "data", ["x", "y"]) in sent       # not the joints' names
    shot = page.shot
    assert len(page.members.data["xs"]) == len(shot.turn.speeds)


def test_the_drawn_curves_are_the_evaluators_to_six_digits():
    page = Page(Session.open(DISC))
    t = page.shot.turn
    for drawn, exact in zip(page.members.data["ys"], t.speeds):
        exact = np.append(exact, exact[0])
        largest = np.max(np.abs(exact))
        assert isinstance(drawn, list)               # in the message's text
        assert np.max(np.abs(np.array(drawn) - exact)) <= \
            0.5 * 10.0 ** (np.floor(np.log10(largest)) - 5)
    drawn = np.asarray(page.paths.data["x"])        # every joint's path, NaN between them
    exact = np.concatenate([np.append(t.positions[:, j, 0], np.nan)
                            for j in range(len(t.names))])
    assert drawn.dtype == np.float32
    assert np.array_equal(np.isnan(drawn), np.isnan(exact))
    assert np.nanmax(np.abs(drawn - exact)) <= 1e-6 * np.nanmax(np.abs(exact))
    assert _drawn(np.array([33.7261725432, -41.23456789])) == [33.7262, -41.2346]


@pytest.mark.parametrize("problem", ["sharkov2022_disc.yaml", "free_design.yaml"])
def test_the_page_uses_no_deprecated_spelling(problem):
    """Panel 1.9 deprecates a widget's ``name`` (for ``label``) and a button's
    ``button_type`` (for ``color``): building and redrawing the page warns of nothing."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        warnings.simplefilter("error", PendingDeprecationWarning)
        page = Page(Session.open(ROOT / "problems" / problem))
        _sent(page, lambda s: s.set(page.session.lengths()[0][0],
                                    page.session.values[page.session.lengths()[0][0]] + 1))


def test_the_number_field_shows_the_steps_decimals():
    """The field beside a slider shows a value to its step's decimals (up to four where it
    lies between steps); the value itself is not rounded."""
    assert _shown(0.2) == "0.0[000]" and _shown(0.05) == "0.00[00]"
    assert _shown(1) == "0[.][0000]" and _shown(0.0001) == "0.0000"
    page = Page(Session.open(DISC))
    w = page.lengths["l3"]
    assert w.step == 0.2 and w._value_edit.format == "0.0[000]"
    w._slider.value = 57.00000000000001      # what the browser's arithmetic sends
    assert w.value == 57.00000000000001 == page.session.values["l3"]

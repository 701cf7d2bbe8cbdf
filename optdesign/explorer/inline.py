"""The explorer's outermost row, shown in a notebook in one pass over its Bokeh models.

In a notebook the explorer's scripts and styles travel with it (``pn.extension(inline=True)``:
nothing from the internet), so Panel replaces every model's imported stylesheets by inline
ones as it displays the page, one model at a time. Each of those assignments makes Bokeh
collect the document's whole model graph again: on a small four-bar front's page, 54 times
and more than a second of the two or three its display took. :class:`InlineRow` makes the same
assignments while the document's models are frozen, so Bokeh collects the graph once, after
them; Panel's own pass then finds every stylesheet inline already and assigns nothing. The
page shown is the same (tests/explorer/test_inline.py compares the two displays).
"""
from __future__ import annotations

import panel as pn
from bokeh.models import UIElement
from panel.io.notebook import patch_inline_stylesheets


class InlineRow(pn.Row):
    """A :class:`panel.Row` whose models' stylesheets are made inline within one freeze of
    the document's models (where Panel displays inline)."""

    def _render_model(self, doc=None, comm=None):
        if doc is None or not pn.config.inline:
            return super()._render_model(doc, comm)
        with doc.models.freeze():
            model = super()._render_model(doc, comm)
            for sub in model.select({"type": UIElement}):
                patch_inline_stylesheets(sub)
        return model

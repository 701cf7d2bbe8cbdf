"""Results that show themselves in a notebook: ``to_frame()`` and an HTML table."""
from __future__ import annotations

import html


class Tabular:
    """Mixin of the result classes: ``to_frame()`` (a pandas DataFrame), a one-line
    ``summary()``, and ``_repr_html_`` (Jupyter shows the summary above the frame)."""

    def to_frame(self):                                    # pragma: no cover - abstract
        raise NotImplementedError

    def summary(self) -> str:                              # pragma: no cover - abstract
        raise NotImplementedError

    def shown_frame(self):
        """The frame the HTML representation shows (:meth:`to_frame` unless overridden)."""
        return self.to_frame()

    def _repr_html_(self) -> str:
        table = self.shown_frame().to_html(float_format=lambda v: f"{v:.6g}", na_rep="–",
                                        index=False, border=0)
        return f"<p><b>{html.escape(self.summary())}</b></p>\n{table}"

"""Figures saved faster and pixel for pixel the same: the tight box measured without drawing
(optdesign.outputs.atomic; a figure laid out by ``tight_layout`` or the constrained engine
too), and the mechanism drawing rendered as two bands by two processes and joined
(optdesign.outputs.split_figure)."""
import io
from functools import partial

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from PIL import Image  # noqa: E402

from optdesign.evaluation.design import Design  # noqa: E402
from optdesign.figures.design import (BANDS, mechanism_figure, plot_mechanism,  # noqa: E402
                                      plot_speeds)
from optdesign.outputs import split_figure  # noqa: E402
from optdesign.outputs.atomic import atomic_savefig  # noqa: E402
from optdesign.outputs.split_figure import save_split  # noqa: E402
from tests.test_figures import DESIGNS  # noqa: E402


@pytest.fixture(autouse=True)
def close_figures():
    yield
    plt.close("all")


def _pixels(data: bytes) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(data)))


def _tight(fig, dpi: float = 120) -> np.ndarray:
    """The pixels savefig writes with its own "tight" (drawing the figure twice)."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, bbox_inches="tight")
    return _pixels(buf.getvalue())


@pytest.mark.parametrize("mechanism", sorted(DESIGNS))
def test_the_figures_saved_with_the_box_measured_beforehand_are_the_tight_ones(mechanism,
                                                                              tmp_path):
    design = Design(mechanism, DESIGNS[mechanism])
    for plot in (partial(plot_mechanism, design), partial(plot_speeds, design, "forward", 97.0)):
        path = atomic_savefig(plot(), tmp_path / "fig.png")
        assert np.array_equal(_pixels(path.read_bytes()), _tight(plot()))


def _laid_out():
    """Panels laid out once by ``tight_layout`` (as the front's, the drive's and the atlas's
    figures are), which leaves matplotlib's placeholder engine on the figure."""
    fig, axes = plt.subplots(2, 3, figsize=(9, 5), sharex=True)
    for k, ax in enumerate(axes.ravel()[:5]):
        ax.plot(np.linspace(0.1, 0.6, 9), np.linspace(k, 3 * k + 1, 9) ** 2, marker="o",
                label=f"n = {k + 4}")
        ax.axhline(k, ls="--", lw=1.0)
        ax.annotate(f"lower {k:g}", (1.0, k), xycoords=("axes fraction", "data"), ha="right")
        ax.set_title(f"l{k}")
        ax.set_ylabel(f"l{k} [mm]")
    axes.ravel()[-1].set_visible(False)
    axes[0, 0].legend(fontsize=7.5)
    fig.suptitle("free lengths along the front")
    fig.tight_layout()
    return fig


def test_a_figure_laid_out_by_tight_layout_is_drawn_once_to_savefigs_pixels(tmp_path,
                                                                           monkeypatch):
    from matplotlib.figure import Figure
    from matplotlib.layout_engine import PlaceHolderLayoutEngine

    fig = _laid_out()
    engine = fig.get_layout_engine()
    assert isinstance(engine, PlaceHolderLayoutEngine)
    drawn, draw = [], Figure.draw
    monkeypatch.setattr(Figure, "draw", lambda self, renderer: drawn.append(1) or
                        draw(self, renderer))
    path = atomic_savefig(fig, tmp_path / "laid_out.png")
    assert len(drawn) == 1                              # savefig's own "tight" draws twice
    assert fig.get_layout_engine() is engine            # given back after the save
    monkeypatch.undo()
    assert np.array_equal(_pixels(path.read_bytes()), _tight(_laid_out()))


def _constrained():
    """Two panels under the constrained engine, which lays the figure out at each drawing
    (as the simulation's angles are drawn: a shared time axis, legends, a long title)."""
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7.5, 5.6), sharex=True,
                                      layout="constrained", height_ratios=[1.6, 1])
    t = np.linspace(0.0, 0.064, 400)
    top.plot(t, np.sin(40 * t), label="ψ (output shaft)")
    top.set_title("a title as long as the drive's: angles over the steady cycle, ε_max")
    bottom.plot(t, 0.01 * np.cos(40 * t) ** 2, label="ε1")
    bottom.set_xlabel("t, s")
    for ax in (top, bottom):
        ax.legend(loc="upper left", fontsize=8)
        ax.set_ylabel("angle, rad")
    return fig


@pytest.mark.parametrize("dpi", [72, 110, 120])
def test_a_figure_under_the_constrained_engine_is_laid_out_and_drawn_once(tmp_path, dpi,
                                                                          monkeypatch):
    """Its layout made once at the file's dpi (savefig's first drawing makes it so), then
    one drawing: savefig's own pixels, and the engine given back."""
    from matplotlib.figure import Figure
    from matplotlib.layout_engine import ConstrainedLayoutEngine

    fig = _constrained()
    engine = fig.get_layout_engine()
    drawn, draw = [], Figure.draw
    laid_out, execute = [], ConstrainedLayoutEngine.execute
    monkeypatch.setattr(Figure, "draw", lambda self, renderer: drawn.append(1) or
                        draw(self, renderer))
    monkeypatch.setattr(ConstrainedLayoutEngine, "execute", lambda self, f: laid_out.append(1)
                        or execute(self, f))
    path = atomic_savefig(fig, tmp_path / "constrained.png", dpi=dpi)
    assert (len(drawn), len(laid_out)) == (1, 1)        # savefig's own: two and one
    assert fig.get_layout_engine() is engine
    monkeypatch.undo()
    assert np.array_equal(_pixels(path.read_bytes()), _tight(_constrained(), dpi))


@pytest.mark.parametrize("mechanism", sorted(DESIGNS))
def test_the_mechanism_drawing_in_two_bands_has_the_pixels_of_the_whole(mechanism, tmp_path):
    build = partial(mechanism_figure, Design(mechanism, DESIGNS[mechanism]), title="t")
    joined = split_figure._joined(build, BANDS, 120)
    assert joined is not None                      # the bands were drawn apart and joined
    whole = _tight(build())
    assert np.array_equal(joined, whole)
    path = save_split(build, BANDS, tmp_path / "mechanism.png", split=True)
    assert np.array_equal(_pixels(path.read_bytes()), whole)


def _overlapping(bands=("left", "right")):
    """Two panels whose boxes overlap: no row between them to join at."""
    fig = plt.figure(figsize=(4, 3))
    for name, rect in (("left", (0.1, 0.1, 0.5, 0.8)), ("right", (0.4, 0.2, 0.5, 0.7))):
        if name in bands:
            ax = fig.add_axes(rect)
            ax.plot([0, 1], [1, 0] if name == "right" else [0, 1])
            ax.set_title(name)
    return fig


def test_bands_with_no_gap_between_them_are_drawn_whole(tmp_path):
    assert split_figure._joined(_overlapping, ("left", "right"), 120) is None
    path = save_split(_overlapping, ("left", "right"), tmp_path / "f.png", split=True)
    assert np.array_equal(_pixels(path.read_bytes()), _tight(_overlapping()))

"""Figures a designer hands over: the labelled mechanism drawing of every mechanism, the lengths
along a Pareto front with their bounds, and labels that never overlap (the accuracy figure)."""
import math

import matplotlib
import numpy as np
import pandas as pd
import pytest

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from optdesign.analyses.accuracy import plot_accuracy  # noqa: E402
from optdesign.evaluation.design import Design  # noqa: E402
from optdesign.fronts.report import plot_lengths  # noqa: E402
from optdesign.figures.design import linkage, place_labels, plot_mechanism  # noqa: E402

#: one design of every registered mechanism (the papers' own sizes)
DESIGNS = {
    "fourbar_converter": dict(l0=225.0, l1=20.0, l2=225.0, l2_prime=100.0, l3=56.0, phases=6),
    "slotted_lever": dict(XD=292.0, L=74.0, sections=2),
    "pulse_reducer": dict(r1=5.0, a=50.0, R1=250.0, freewheels=2),
}


@pytest.fixture(autouse=True)
def close_figures():
    yield
    plt.close("all")


def _texts(fig) -> list[str]:
    return [t.get_text() for ax in fig.axes for t in ax.texts]


def _disjoint(boxes) -> bool:
    return not any(a.overlaps(b) for i, a in enumerate(boxes) for b in boxes[i + 1:])


def test_the_converter_drawing_names_its_joints_in_mm_with_legend_and_lengths():
    fig = plot_mechanism(Design("fourbar_converter", DESIGNS["fourbar_converter"]),
                         title="paper design")
    texts = _texts(fig)
    assert {"O", "A", "B1", "O1", "C2", "B6", "O6"} <= set(texts)
    main = fig.axes[0]
    assert "mm" in main.get_xlabel() and "mm" in main.get_ylabel()
    legends = [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
    assert len(legends) == 1
    entries = [t.get_text() for t in legends[0].get_texts()]
    assert {"crank", "couplers / rods", "rockers", "fixed pivots", "moving joints",
            "crank circle (l1 = 20 mm)", "rocker swing over a turn"} <= set(entries)
    cells = [c.get_text().get_text() for ax in fig.axes for t in ax.tables
             for c in t.get_celld().values()]
    assert {"l1", "20.00", "l3", "56.00", "phases", "6"} <= set(cells)
    # the 20 mm crank beside 225 mm rods gets a magnified panel of its own
    detail = next(ax for ax in fig.axes if ax.get_title() == "crank detail")
    assert np.ptp(detail.get_xlim()) < np.ptp(main.get_xlim()) / 3
    assert {"O", "A"} <= {t.get_text() for t in detail.texts}
    assert _disjoint([t.get_window_extent() for t in main.texts])


@pytest.mark.parametrize("mechanism", sorted(DESIGNS))
def test_every_mechanism_is_drawn_with_every_joint_named(mechanism):
    design = Design(mechanism, DESIGNS[mechanism])
    fig = plot_mechanism(design, angles_deg=(30, 120))
    _, names, _ = design.model.joints(design.count, design.option_key)
    assert set(names) <= set(_texts(fig))
    assert len(fig.axes[0].lines) > len(names)     # links, joints and the crank's path


def test_roles_are_read_from_the_motion_and_paths_follow_the_lengths():
    """A fixed pivot never moves; the crank turns with φ1; the crank end circles at l1·e and
    each rocker end swings on its arc at l3 from its pivot (to rounding, 1e-9 mm)."""
    link = linkage(Design("fourbar_converter", DESIGNS["fourbar_converter"]), 0.5)
    assert link.fixed == {"O"} | {f"O{i}" for i in range(1, 7)}
    assert link.roles[("O", "A")] == "crank" and link.crank_pivot == "O"
    assert link.roles[("O1", "B1")] == "rocker" and link.roles[("A", "B1")] == "coupler"
    assert np.hypot(*link.path("A").T) == pytest.approx(10.0, abs=1e-9)
    b3 = link.path("B3") - link.path("O3")
    assert np.hypot(*b3.T) == pytest.approx(56.0, abs=1e-9)
    assert np.ptp(np.unwrap(np.arctan2(b3[:, 1], b3[:, 0]))) < math.pi    # an arc, not a turn
    lever = linkage(Design("slotted_lever", DESIGNS["slotted_lever"]))
    assert lever.roles[("O", "A1")] == "crank" and lever.roles[("D", "A1")] == "rocker"
    reducer = linkage(Design("pulse_reducer", DESIGNS["pulse_reducer"]))
    assert reducer.roles[("O", "A")] == "crank" and reducer.roles[("A", "P2")] == "rocker"


def test_the_drawing_fills_axes_a_caller_gives():
    fig, axes = plt.subplots(1, 2)
    out = plot_mechanism(Design("fourbar_converter", DESIGNS["fourbar_converter"]),
                         angles_deg=(0, 180), axes=axes)
    assert out is fig and axes[0].get_legend() is not None
    assert {"O", "A", "B1"} <= {t.get_text() for t in axes[1].texts}


def test_labels_that_find_no_room_are_left_out_never_overlapped():
    fig, ax = plt.subplots(figsize=(3, 2))
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1)
    points = [(0.5 + 0.004 * k, 0.5) for k in range(30)]
    placed = place_labels(ax, points, [f"{1800 + k}" for k in range(30)], force=False)
    shown = [t for t in placed if t is not None]
    assert 1 < len(shown) < 30
    assert _disjoint([t.get_window_extent() for t in shown])


def test_the_accuracy_figure_labels_do_not_overlap():
    """Runs of equal errors at nearly equal times (the surrogate's) merged their labels."""
    rows = [{"method": "surrogate", "samples": n, "smoothing": rho, "delta_error": 3e-11,
             "time_s": 0.02 * (1 + 0.1 * j + 0.03 * i)}
            for i, rho in enumerate((50, 200, 1000)) for j, n in enumerate((30, 45, 60, 90))]
    rows += [{"method": "sampled", "samples": 2 ** k, "smoothing": None,
              "delta_error": 2.0 ** -k, "time_s": 1e-4 * 2 ** (k / 3)} for k in range(4, 17)]
    fig = plot_accuracy(rows)
    ax = fig.axes[0]
    labels = [t for t in ax.texts]
    assert "16" in {t.get_text() for t in labels} and "65536" in {t.get_text() for t in labels}
    assert _disjoint([t.get_window_extent() for t in labels])
    assert ax.get_legend() is not None


def _front() -> pd.DataFrame:
    ratio = np.linspace(0.8, 0.85, 5)
    rows = [{"count": n, "phases": n, "ratio": r + 0.02 * (n == 6), "delta": 0.1 + r,
             "l1": 20 + 80 * (r - 0.8), "l3": 30.0, "status": "optimal", "count_front": True}
            for n in (4, 6) for r in ratio]
    df = pd.DataFrame(rows)
    df.attrs["knee"] = 7
    return df


def test_lengths_along_the_front_one_panel_per_free_length_with_its_bounds():
    bounds = {"l1": (10.0, 60.0), "l3": (30.0, 150.0)}
    fig = plot_lengths(_front(), bounds)
    axes = [ax for ax in fig.axes if ax.get_visible()]
    assert [ax.get_title() for ax in axes] == ["l1", "l3"]
    for ax, (name, (lower, upper)) in zip(axes, bounds.items()):
        dashed = {float(line.get_ydata()[0]) for line in ax.lines
                  if line.get_linestyle() == "--" and np.ptp(line.get_ydata()) == 0}
        assert dashed == {lower, upper}
        assert ax.get_ylim()[0] < lower and ax.get_ylim()[1] > upper
        assert "mm" in ax.get_ylabel() and "ratio" in ax.get_xlabel()
        fronts = [line for line in ax.lines if line.get_label().startswith("n = ")]
        assert len(fronts) == 2 and all(len(line.get_xdata()) == 5 for line in fronts)
    assert axes[0].get_legend() is not None

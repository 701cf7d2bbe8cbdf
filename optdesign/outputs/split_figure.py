"""One figure rendered by two processes at once: its upper and its lower band, joined.

A figure is saved in the time of its slower half when its panels fall into two bands, one
above the other with a gap between them (:func:`optdesign.figures.design.mechanism_figure`:
the linkage, its legend and lengths; the small drawings below). Each of two processes builds
the figure with only its band's panels, each where it is in the whole figure, and measures
them; the tight box is the union of the two bands' boxes (the box savefig's "tight" finds
for the whole figure), each process renders its band cropped to that box, and the PNG takes
the rows above a row in the gap from the upper band's render and the rows below it from the
lower band's.

These are the pixels of the whole figure rendered at once, and that is checked for each
figure, not assumed: the bands' boxes must leave :data:`GAP` pixels between them, and each
band's render must hold nothing but the figure's background on the other side of the join.
Where a check fails, or the second process does not deliver, the whole figure is drawn here,
as :func:`optdesign.outputs.atomic.atomic_savefig` saves it.
"""
from __future__ import annotations

import io
import os
import signal
from pathlib import Path
from typing import Callable

from optdesign.lifetime import die_with_parent
from optdesign.outputs.atomic import atomic_savefig, atomic_write_bytes, content_bbox, padded

#: the least gap [pixels] between the bands' boxes: a label's rounded box reaches a little
#: beyond its text, which the boxes measure
GAP = 8


def save_split(build: Callable, bands: tuple[str, str], path: str | Path, dpi: float = 120,
               split: bool = True, metadata: dict | None = None) -> Path:
    """The figure ``build(bands=bands)`` saved as a PNG at ``path``, as ``atomic_savefig(fig,
    path, dpi=dpi, metadata=metadata)`` saves it (``metadata``: the PNG's text); with
    ``split``, rendered as its two ``bands`` (upper, lower:
    ``build(bands=(upper,))`` and ``build(bands=(lower,))``) by this process and one forked
    from it.

    Split only in a process that may fork at any time (a figures' process of
    :class:`~optdesign.outputs.figure_process.FigureProcess`: no thread of the command's)."""
    if split and hasattr(os, "fork"):
        rgba = _joined(build, bands, dpi)
        if rgba is not None:
            return atomic_write_bytes(path, _png(rgba, dpi, metadata))
    return _saved(build(bands=bands), path, dpi, metadata)


def _joined(build: Callable, bands: tuple[str, str], dpi: float):
    """The whole figure's pixels (rows × columns × RGBA) from its two bands, or None."""
    from multiprocessing import Pipe

    here, there = Pipe()
    parent = os.getpid()
    pid = os.fork()
    if pid == 0:                                # the lower band: never returns
        try:
            here.close()
            die_with_parent(parent)
            _lower(build(bands=bands[1:]), there, dpi)
        finally:
            os._exit(0)
    there.close()
    try:
        return _upper(build(bands=bands[:1]), here, dpi)
    except (EOFError, OSError):                 # the lower band's process ended early
        return None
    finally:
        here.close()
        try:
            os.kill(pid, signal.SIGKILL)        # done or not, it has nothing more to give
        except ProcessLookupError:
            pass
        os.waitpid(pid, 0)


def _upper(fig, conn, dpi: float):
    """Measure the upper band, agree on the box and the join, render, and take the lower
    band's rows below the join; None where a check fails."""
    import numpy as np
    from matplotlib.transforms import Bbox

    try:
        mine = content_bbox(fig, dpi)
        theirs = Bbox(conn.recv())
        box = padded(Bbox.union([mine, theirs]))
        gap = (mine.y0 - theirs.y1) * dpi
        join = round((box.y1 - (mine.y0 + theirs.y1) / 2) * dpi)   # a row, from the top
        if gap < GAP:
            conn.send(None)
            return None
        conn.send((box.get_points(), join))
        rgba = _rendered(fig, box, dpi)
        blank_above = conn.recv()
        below = conn.recv_bytes()
    finally:
        _close(fig)
    if not (blank_above and _blank(rgba[join:], rgba[0, 0])
            and len(below) == rgba[join:].nbytes):
        return None
    rgba[join:] = np.frombuffer(below, np.uint8).reshape(rgba[join:].shape)
    return rgba


def _lower(fig, conn, dpi: float) -> None:
    """Measure the lower band, render it in the box agreed on, send its rows below the
    join and whether those above it are blank."""
    from matplotlib.transforms import Bbox

    conn.send(content_bbox(fig, dpi).get_points())
    plan = conn.recv()
    if plan is None:
        return
    points, join = plan
    rgba = _rendered(fig, Bbox(points), dpi)
    conn.send(_blank(rgba[:join], rgba[0, 0]))
    conn.send_bytes(memoryview(rgba[join:]).cast("B"))


def _rendered(fig, box, dpi: float):
    """``fig`` rendered by Agg cropped to ``box`` [inches], as savefig renders a PNG."""
    import numpy as np

    fig.savefig(io.BytesIO(), format="raw", dpi=dpi, bbox_inches=box)
    return np.array(fig.canvas.buffer_rgba())


def _blank(rows, background) -> bool:
    """True when every pixel of ``rows`` is ``background``."""
    return bool((rows == background).all())


def _png(rgba, dpi: float, metadata: dict | None = None) -> bytes:
    """``rgba`` as the PNG savefig writes of it."""
    from matplotlib.image import imsave

    buf = io.BytesIO()
    imsave(buf, memoryview(rgba), format="png", origin="upper", dpi=dpi, metadata=metadata)
    return buf.getvalue()


def _saved(fig, path, dpi: float, metadata: dict | None = None) -> Path:
    try:
        return atomic_savefig(fig, path, dpi=dpi, metadata=metadata)
    finally:
        _close(fig)


def _close(fig) -> None:
    import matplotlib.pyplot as plt

    plt.close(fig)

"""Atomic file writing: a crash or a kill never leaves a half-written result behind."""
from __future__ import annotations

import json
import math
import os
import tempfile
from contextlib import contextmanager, nullcontext
from pathlib import Path

#: The layout version of every JSON document the package writes or prints: its
#: ``schema_version`` key, beside a ``units`` block (:func:`optdesign.outputs.units.stamped`;
#: docs/contract.md, "Schema version and units"). Bump the minor part ("1.1" -> "1.2") when
#: keys are added or one is deprecated (its alias kept beside the new name): a reader of the
#: old layout keeps working. Bump the major part ("1.x" -> "2.0") when a key is removed,
#: renamed without an alias, or changes its meaning or unit. Documents without the key are
#: "1.0" (before 1.1 added ``schema_version``, ``units`` and ``omega_midrange``); 1.2 added
#: ``quantities`` (optdesign.quantities) and a Pareto record's ``gain`` on a front against
#: another quantity than the ratio.
SCHEMA_VERSION = "1.2"


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    """Write to a temporary file in the same folder, fsync, then rename over ``path``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = None
    try:
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, 0o666 & ~_umask())      # mkstemp makes 0600: give the usual rights
        os.replace(tmp, path)
    except OSError as exc:
        if tmp is not None:
            Path(tmp).unlink(missing_ok=True)
        # a write or an fsync names no file, and a temporary's name means nothing to the
        # user ("No space left on device"): name the file that could not be written
        if exc.filename is None or exc.filename == tmp or exc.filename2 is not None:
            raise OSError(exc.errno, exc.strerror, str(path)) from None
        raise
    except BaseException:
        if tmp is not None:
            Path(tmp).unlink(missing_ok=True)
        raise
    return path


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def atomic_write_text(path: str | Path, text: str) -> Path:
    return atomic_write_bytes(path, text.encode("utf-8"))


def atomic_write_json(path: str | Path, data) -> Path:
    return atomic_write_text(path, json_text(data) + "\n")


def json_text(data, indent: int | None = 2, reasons: bool = True) -> str:
    """Strict JSON of ``data`` (no NaN, no Infinity: :func:`finite_json`), NumPy values
    included; what every JSON file and ``--json`` print of the package is made of.
    ``reasons=False`` leaves out the ``non_finite`` keys (records read back as table rows)."""
    return json.dumps(finite_json(data, reasons), indent=indent, allow_nan=False,
                      default=_jsonable)


#: the key a JSON object gains when some of its numbers were not finite (docs/contract.md)
NON_FINITE_KEY = "non_finite"


def finite_json(value, reasons: bool = True):
    """``value`` with every float that is not finite replaced by None (JSON null). A mapping
    that held one gains ``non_finite``: {key: "inf" | "-inf" | "nan"}, so a reader can tell
    an infinite ripple from a missing one. NumPy scalars and arrays become Python ones."""
    value = _plain(value)
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        out, why = {}, {}
        for k, v in value.items():
            v = _plain(v)
            if isinstance(v, float) and not math.isfinite(v):
                why[str(k)] = "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf")
            out[k] = finite_json(v, reasons)
        if why and reasons:
            old = out.get(NON_FINITE_KEY)
            out[NON_FINITE_KEY] = {**old, **why} if isinstance(old, dict) else why
        return out
    if isinstance(value, (list, tuple)):
        return [finite_json(v, reasons) for v in value]
    return value


def _plain(value):
    """A NumPy scalar or array as the Python value it holds; anything else unchanged."""
    if type(value).__module__ == "numpy":
        return _jsonable(value)
    return value


def atomic_savefig(fig, path: str | Path, **kwargs) -> Path:
    """Save a matplotlib figure atomically (PNG unless the suffix says otherwise)."""
    import io

    buf = io.BytesIO()
    fmt = Path(path).suffix.lstrip(".") or "png"
    options = {"dpi": 120, "bbox_inches": "tight"} | kwargs
    measured = options["bbox_inches"] == "tight" and _measurable(fig, fmt)
    if measured:
        _lay_out(fig, options["dpi"])
        options["bbox_inches"] = padded(content_bbox(fig, options["dpi"]),
                                        options.pop("pad_inches", None))
    with _layout_done(fig) if measured else nullcontext():
        fig.savefig(buf, format=fmt, **options)
    return atomic_write_bytes(path, buf.getvalue())


def _measurable(fig, fmt: str) -> bool:
    """True when :func:`content_bbox` gives the box savefig's "tight" finds for ``fig``: a
    PNG of an Agg canvas without a layout engine, with matplotlib's placeholder engine (a
    figure laid out once by ``fig.tight_layout()``: it lays out nothing at a drawing) or with
    the constrained engine (the simulation's, the curves' and the drive shaft's figures),
    whose layout :func:`_lay_out` makes once, as savefig's first drawing would."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.layout_engine import ConstrainedLayoutEngine, PlaceHolderLayoutEngine

    engine = fig.get_layout_engine()
    return (fmt == "png" and isinstance(fig.canvas, FigureCanvasAgg)
            and (engine is None
                 or isinstance(engine, (PlaceHolderLayoutEngine, ConstrainedLayoutEngine))))


def _lay_out(fig, dpi: float) -> None:
    """The constrained engine's layout of ``fig`` made at ``dpi``, as savefig's unseen
    first drawing makes it before it measures the tight box (the layout measures the text at
    the dpi of the file); other figures are left as they are."""
    from matplotlib.layout_engine import ConstrainedLayoutEngine

    engine = fig.get_layout_engine()
    if isinstance(engine, ConstrainedLayoutEngine) and fig.axes:
        with _at_dpi(fig, dpi):
            engine.execute(fig)


@contextmanager
def _layout_done(fig):
    """``fig`` without its layout engine while it is saved: savefig draws a figure that
    holds any engine once unseen before it renders it, for a layout that the placeholder
    does not make and :func:`_lay_out` has made; the engine is given back after."""
    engine = fig.get_layout_engine()
    if engine is None:
        yield
        return
    import matplotlib as mpl

    with mpl.rc_context({"figure.autolayout": False, "figure.constrained_layout.use": False}):
        fig.set_layout_engine(None)         # None under these settings: no engine at all
    try:
        yield
    finally:
        fig.set_layout_engine(engine)


def content_bbox(fig, dpi: float):
    """The box [inches] around what ``fig`` shows, measured at ``dpi`` without drawing it:
    ``savefig(bbox_inches="tight")`` draws a figure twice, once unseen to lay it out and find
    this box, then to render it; given the box (:func:`padded`), once, to the same pixels."""
    with _at_dpi(fig, dpi):
        return fig.get_tightbbox(fig.canvas.get_renderer())


@contextmanager
def _at_dpi(fig, dpi: float):
    """``fig`` at ``dpi`` (the file's, as savefig sets it) for a while, then at its own."""
    kept = fig.dpi
    fig.dpi = dpi
    try:
        yield
    finally:
        fig.dpi = kept


def padded(bbox, pad_inches: float | None = None):
    """``bbox`` with savefig's margin around it (``savefig.pad_inches`` unless given)."""
    import matplotlib as mpl

    pad = mpl.rcParams["savefig.pad_inches"] if pad_inches is None else pad_inches
    return bbox.padded(pad)


def _jsonable(value):
    try:
        import numpy as np
        if isinstance(value, np.generic):
            return value.item()
        if isinstance(value, np.ndarray):
            return value.tolist()
    except ImportError:          # pragma: no cover
        pass
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")

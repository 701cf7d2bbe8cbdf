"""The linkage to scale at one crank angle, as a DXF document (ezdxf).

Everything is in millimetres in the mechanism's own frame (the crank centre O at the origin,
``$INSUNITS`` = mm). Layers by role, each with its colour (AutoCAD colour index):

* ``FRAME``: the fixed pivots (a circle each) and the frame lines from the crank's pivot to
  every other fixed pivot;
* ``CRANK``, ``COUPLER``, ``ROCKER``: the links at the angle (their roles read off the motion,
  :class:`~optdesign.figures.design.Linkage`), the moving joints as small circles;
* ``PATHS``: the crank circle, each rocker end's swing arc over the turn and the coupler
  joints' paths (polylines);
* ``TITLE``: the title block: name, mechanism, count, eccentricity and angle, each length, δ,
  the ratio and the least transmission angle.

The design's lengths, count and figures are also stored at full precision as custom header
properties (``$CUSTOMPROPERTY``), so a reader gets them back exactly.
"""
from __future__ import annotations

import math

import numpy as np

from optdesign.figures.design import linkage

#: layer -> (AutoCAD colour index: 1 red, 5 blue, 94 dark green, 8 and 9 greys, 7 black on
#: white; lineweight in 1/100 mm)
LAYERS = {"FRAME": (8, 25), "CRANK": (1, 70), "COUPLER": (5, 50), "ROCKER": (94, 70),
          "PATHS": (9, 18), "TITLE": (7, 25)}
#: a joint's circle, as a share of the drawing's extent
JOINT_SHARE = 0.008
#: samples of a path over the turn
PATH_SAMPLES = 360


def linkage_document(design, title: dict, angle_deg: float = 0.0, eccentricity: float = 1.0):
    """The ezdxf document of ``design`` at crank angle ``angle_deg`` (and ``eccentricity``).

    ``title``: the title block's lines after the name, ``{label: value}`` (value a number or
    text), e.g. δ and the ratio; stored as custom properties too."""
    import ezdxf
    from ezdxf import units

    drawn = linkage(design, eccentricity, PATH_SAMPLES)
    doc = ezdxf.new("R2018", setup=True)
    doc.units = units.MM
    doc.header["$MEASUREMENT"] = 1                     # metric
    for name, (colour, weight) in LAYERS.items():
        doc.layers.add(name, color=colour, lineweight=weight)
    msp = doc.modelspace()
    at = {k: np.asarray(v, dtype=float) for k, v in drawn.at(angle_deg).items()}
    low, high = drawn.bounds()
    extent = float(max(high - low))
    pin = JOINT_SHARE * extent

    pivot = drawn.crank_pivot
    for joint in drawn.names:
        layer = "FRAME" if joint in drawn.fixed else _layer_of(drawn, joint)
        msp.add_circle(tuple(at[joint]), pin * (1.6 if joint in drawn.fixed else 1.0),
                       dxfattribs={"layer": layer})
    for link, role in drawn.roles.items():
        a, b = link
        msp.add_line(tuple(at[a]), tuple(at[b]), dxfattribs={"layer": role.upper()})
    if pivot is not None:
        for joint in sorted(drawn.fixed - {pivot}):
            msp.add_line(tuple(at[pivot]), tuple(at[joint]), dxfattribs={"layer": "FRAME"})
        for end in drawn.ends("crank"):
            radius = float(np.hypot(*(at[end] - at[pivot])))
            msp.add_circle(tuple(at[pivot]), radius, dxfattribs={"layer": "PATHS"})
    for (a, b), role in drawn.roles.items():
        if role == "rocker":
            centre, end = (a, b) if a in drawn.fixed else (b, a)
            _swing_arc(msp, drawn, centre, end)
    for joint in drawn.ends("coupler"):
        if joint not in drawn.ends("crank") and joint not in drawn.ends("rocker"):
            msp.add_lwpolyline([tuple(p) for p in drawn.path(joint)], close=True,
                               dxfattribs={"layer": "PATHS"})
    _title_block(msp, title, low, high, extent)
    for label, value in title.items():
        doc.header.custom_vars.append(label, repr(value) if isinstance(value, float)
                                      else str(value))
    return doc


def _layer_of(drawn, joint: str) -> str:
    """The layer of a moving joint: the crank's end, a rocker's end, else a coupler's."""
    for role in ("crank", "rocker", "coupler"):
        if joint in drawn.ends(role):
            return role.upper()
    return "COUPLER"


def _swing_arc(msp, drawn, centre: str, end: str) -> None:
    """The arc the rocker's end sweeps about its pivot over the turn (its swing angle)."""
    v = drawn.path(end) - drawn.path(centre)
    angles = np.unwrap(np.arctan2(v[:, 1], v[:, 0]))
    radius = float(np.hypot(*v[0]))
    lo, hi = math.degrees(angles.min()), math.degrees(angles.max())
    msp.add_arc(tuple(drawn.path(centre)[0]), radius, lo, hi, dxfattribs={"layer": "PATHS"})


def _title_block(msp, title: dict, low, high, extent: float) -> None:
    """The title lines below the drawing, left-aligned with it."""
    height = 0.018 * extent
    x, y = float(low[0]), float(low[1]) - 2.5 * height
    for i, (label, value) in enumerate(title.items()):
        text = f"{label}: {value:.6g}" if isinstance(value, float) else f"{label}: {value}"
        msp.add_text(text, height=height, dxfattribs={"layer": "TITLE"}).set_placement(
            (x, y - i * 1.6 * height))

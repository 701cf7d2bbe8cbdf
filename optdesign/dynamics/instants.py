"""The paper's instants of a cycle (Ambartsumyants & Subbotina 2015, Fig. 2).

A freewheel closes (t0); its relative angle ε rises (jamming) to a maximum (t1), falls back to 0
where it releases (t2, the start of the overrun); then the next freewheel closes (t3).

Only a closing that *carries* counts as t0: one whose ε rises above the switching band before
it releases. A start state whose leading holder is already slowing (the four-bar at φ = 0)
lets its freewheel go at once, with ε never above 0; its instants would all be 0, so the
figures start from the next closing instead.

Simultaneous events are real: at a dead centre one holder stops (its ε peaks) at the very
instant the next one starts (it closes). They keep the order in which the integrator applied
them (the ε peak, found inside the segment, before the switches that end it), so every sort
here is on (time, position in the record) and never compares two events.
"""
from __future__ import annotations


def steady_instants(events: list, period: float, labels: list[str], band: float) -> dict:
    """The instants of the recorded cycle, t = 0 at its first carrying closing; events before
    it belong, in the periodic cycle, one period later."""
    closings = [(e.t, e.wheel) for e in events if e.kind == "engage"]
    found = _carrying(closings, lambda t0: _timeline(events, t0, period), band)
    if found is None:
        return {"note": "no freewheel closes and carries in the recorded cycle"}
    t0, wheel, timeline, t1, t2 = found
    t3 = next((t for t, e in timeline if e.kind == "engage" and t2 is not None and t > t2),
              None)
    if t3 is None and t2 is not None:
        t3 = period                       # only this closing per cycle: it comes back
    return {"freewheel": labels[wheel], "t0_in_turn_s": float(t0),
            "t1_s": _time(t1), "t2_s": _time(t2), "t3_s": _time(t3)}


def first_turn_instants(events: list, labels: list[str], lead: int, band: float) -> dict:
    """The instants of the first turn from the start state, t = 0 at φ = 0 where freewheel
    ``lead`` has just closed: the paper's single computed cycle. ``t0_s`` is the first
    carrying closing (0 for the paper's start at a dead centre), t1 and t2 that freewheel's
    ε maximum and release, t3 the next closing of another freewheel after t2 (of the same
    one when no other closes)."""
    closings = [(0.0, lead)] + [(e.t, e.wheel) for e in events if e.kind == "engage"]
    ordered = _timeline(events, 0.0, None)
    found = _carrying(closings, lambda t0: [(t, e) for t, e in ordered if t >= t0], band)
    if found is None:
        return {"freewheel": None, "t0_s": None, "t1_s": None, "t2_s": None, "t3_s": None,
                "t3_freewheel": None, "eps_max": None,
                "note": "no freewheel closes and carries in the first turn"}
    t0, wheel, timeline, t1, t2 = found
    peak = next(e.eps for t, e in timeline if t == t1 and e.kind == "eps_max"
                and e.wheel == wheel)
    t3 = t3_wheel = None
    if t2 is not None:
        later = [e for t, e in timeline if e.kind == "engage" and t > t2]
        pick = next((e for e in later if e.wheel != wheel), later[0] if later else None)
        if pick is not None:
            t3, t3_wheel = pick.t, labels[pick.wheel]
    return {"freewheel": labels[wheel], "t0_s": float(t0), "t1_s": _time(t1),
            "t2_s": _time(t2), "t3_s": _time(t3), "t3_freewheel": t3_wheel,
            "eps_max": float(peak)}


def _timeline(events: list, origin: float, period: float | None) -> list:
    """(time from ``origin``, event) in time order, wrapped by ``period`` when given; ties
    keep the recorded order."""
    def rel(e):
        return (e.t - origin) % period if period else e.t - origin

    order = sorted(range(len(events)), key=lambda i: (rel(events[i]), i))
    return [(rel(events[i]), events[i]) for i in order]


def _carrying(closings: list, timeline_from, band: float):
    """The first closing (t0, wheel) whose ε rises above ``band`` before it releases, with
    its timeline and its t1, t2; None if none does."""
    for t0, wheel in closings:
        timeline = timeline_from(t0)
        t1, t2 = _jamming(timeline, wheel, band)
        if t1 is not None:
            return t0, wheel, timeline, t1, t2
    return None


def _jamming(timeline: list, wheel: int, band: float):
    """t1 (the first ε maximum of ``wheel`` above ``band``, before its release) and t2 (its
    release), as times of ``timeline``."""
    t2 = next((t for t, e in timeline if e.kind == "release" and e.wheel == wheel), None)
    t1 = next((t for t, e in timeline if e.kind == "eps_max" and e.wheel == wheel
               and e.eps > band and (t2 is None or t <= t2)), None)
    return t1, t2


def _time(t) -> float | None:
    return None if t is None else float(t)

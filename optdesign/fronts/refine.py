"""After the uniform pass: one row per design, dominated points re-solved, the front refined
where it is coarse (docs/pareto.md, "What the sweep does").

Pure functions of the finished records of one phase count, so a resumed sweep plans the very
same work: round r's points are planned from the records of rounds < r alone, and numbered
from one past the largest index among them.

- :func:`visible`: the rows a front shows. A re-solve that improves on the point it replaces
  takes its place (one that does not is dropped); designs of one count whose lengths agree
  within :data:`SAME_LENGTH_REL` are one row (``merged`` counts the others).
- :func:`plan`: the next round's solves. Each point dominated by another verified point of
  its count, or beaten on its own ε-problem by any verified design of its count (a design of
  less δ that reaches its ε: :func:`beater`), is re-solved at its ε from that design (once);
  one still beaten after it is shown ``local``, never ``optimal``. Then new ε values go
  into the gaps of the count's front that are longer than ``max_gap`` in normalised
  (ratio, δ) distance, or where the slope dδ/d ratio (the ε multiplier) turns by more than
  ``max_turn_deg`` between neighbours, at most ``max_points`` in all, the longest gaps first.
- :func:`plan_hypervolume`: once every count's own rounds are finished, rounds over the
  front of every count together: ε values where two neighbours leave more than
  ``hypervolume_gap`` of the normalised hypervolume uncovered (the rectangle between them),
  at most ``hypervolume_points`` in all. Planned from every count's records of the rounds
  before, so a resumed sweep plans these the same way.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from optdesign.fronts.indicators import non_dominated, objectives

#: two designs of one count are one when every length agrees within this share (of the
#: larger magnitude, at least 1 mm): IPOPT's tolerance, far below any manufacturing one
SAME_LENGTH_REL = 1e-4
#: refinement rounds after the uniform pass (each plans from the finished earlier rounds)
MAX_ROUNDS = 4
#: a gap whose open ε interval is narrower than this share of max_gap (normalised ratio) is
#: settled: an ε tried inside it landed on its upper neighbour, so the front jumps there
SETTLED_SHARE = 0.125
#: a slope's turn refines a gap only while the gap is longer than this share of max_gap
TURN_GAP_SHARE = 0.25
#: q dominates p only by more than these shares (not by IPOPT's noise)
DOMINANCE_REL = 1e-6
#: the status of a verified point that a known design beats on its own ε-problem
LOCAL = "local"
#: the statuses of a verified feasible design on a front
VERIFIED = ("optimal", LOCAL)

DEFAULT_MAX_GAP = 0.1
DEFAULT_MAX_POINTS = 12
DEFAULT_MAX_TURN_DEG = 30.0
#: rounds over the front of every count together, after each count's own rounds
HYPERVOLUME_ROUNDS = 4
DEFAULT_HYPERVOLUME_GAP = 3e-5
DEFAULT_HYPERVOLUME_POINTS = 100
#: the resolution a designer reads δ at, and the gain's relative to its size (a ratio of 0.6
#: to 6e-4, a housing radius of 300 mm to 0.3 mm)
DEFAULT_DELTA_RESOLUTION = 1e-4
GAIN_RESOLUTION_REL = 1e-3


@dataclass(frozen=True)
class Refinement:
    """``pareto.refine``: whether and how far the front is refined after the uniform pass;
    ``delta_resolution`` and ``gain_resolution`` (``pareto.resolution``) are the scales a
    designer reads: no point is added between neighbours that differ by less in both."""

    enabled: bool = True
    max_gap: float = DEFAULT_MAX_GAP
    max_points: int = DEFAULT_MAX_POINTS
    max_turn_deg: float = DEFAULT_MAX_TURN_DEG
    hypervolume_gap: float = DEFAULT_HYPERVOLUME_GAP
    hypervolume_points: int = DEFAULT_HYPERVOLUME_POINTS
    delta_resolution: float = DEFAULT_DELTA_RESOLUTION
    #: in the gain's unit; None: GAIN_RESOLUTION_REL of the gain's size (at least 1)
    gain_resolution: float | None = None

    def gain_step(self, a: float, b: float) -> float:
        """The gain resolution between neighbours of gains ``a`` and ``b``."""
        if self.gain_resolution is not None:
            return self.gain_resolution
        return GAIN_RESOLUTION_REL * max(abs(a), abs(b), 1.0)

    def resolvable(self, a: dict, b: dict) -> int:
        """How many parts the stretch between neighbours ``a`` and ``b`` can be split into
        with each part still wider than the resolution in δ or in the gain (0: none, the two
        are one point to a designer)."""
        parts = max(abs(b["delta"] - a["delta"]) / self.delta_resolution,
                    abs(gain(b) - gain(a)) / self.gain_step(gain(a), gain(b)))
        return int(math.floor(parts + 1e-9)) if parts > 1 else 0


@dataclass
class Task:
    """One solve a round plans: ε, its starts, and the point it replaces (a re-solve)."""

    index: int
    epsilon: float
    start: dict
    also: list = field(default_factory=list)
    replaces: int | None = None
    #: the primal-dual optimum that ended on ``start`` (its record's ``warm``), if any
    warm: dict | None = None


def _index(r: dict):
    return r["key"][1]


def gain(r: dict):
    """The front's second objective of a record, larger is better: its ``gain`` on a front
    against another quantity than the ratio (``pareto.against``), else its ratio."""
    return r["gain"] if "gain" in r else r.get("ratio")


def _less(gain: float) -> float:
    """``gain`` less :data:`DOMINANCE_REL` of its size (a gain may be negative: a housing
    radius counts negatively); the ratio's ``ratio·(1 − rel)``."""
    return gain * (1 - DOMINANCE_REL) if gain >= 0 else gain * (1 + DOMINANCE_REL)


def _more(gain: float) -> float:
    return gain * (1 + DOMINANCE_REL) if gain >= 0 else gain * (1 - DOMINANCE_REL)


def _slope(r: dict):
    """d δ / d gain at a record (the ratio's multiplier on a ratio front)."""
    return r["gain_multiplier"] if "gain_multiplier" in r else r.get("ratio_multiplier")


def _ok(r: dict) -> bool:
    return bool(r.get("feasible")) and r.get("delta") is not None and gain(r) is not None


# --------------------------------------------------------------------------- the rows shown
def superseded(records: list[dict]) -> list[dict]:
    """``records`` without the points a better re-solve replaced, nor the re-solves that did
    not improve on their point (a re-solve names the index it replaces in ``replaces``)."""
    by_index = {_index(r): r for r in records}
    dropped = set()
    for r in sorted(records, key=lambda r: (r.get("round") or 0, _index(r))):
        target = r.get("replaces")
        if target is None:
            continue
        old = by_index.get(target)
        if _ok(r) and (old is None or not _ok(old) or
                       r["delta"] < old["delta"] * (1 - DOMINANCE_REL)):
            dropped.add(target)
        else:
            dropped.add(_index(r))
    return [r for r in records if _index(r) not in dropped]


def same_design(a: dict, b: dict, lengths: list[str]) -> bool:
    """One count, every length within :data:`SAME_LENGTH_REL`."""
    if a.get("count") != b.get("count") or not a.get("design") or not b.get("design"):
        return False
    for k in lengths:
        x, y = a["design"].get(k), b["design"].get(k)
        if x is None or y is None:
            return False
        if abs(x - y) > SAME_LENGTH_REL * max(abs(x), abs(y), 1.0):
            return False
    return True


def merge_identical(records: list[dict], lengths: list[str]) -> list[dict]:
    """One record per design (feasible ones; a failed point stays as it is), with ``merged``
    = how many others it stands for. The one kept: an end of the front first, then the one
    of largest ε (where the ratio bound binds, so its multiplier is the slope)."""
    def priority(r):
        return (r.get("kind") == "sweep", -(r.get("epsilon") or 0.0), _index(r))

    kept: list[dict] = []
    absorbed: dict = {}
    for r in sorted((r for r in records if _ok(r)), key=priority):
        twin = next((k for k in kept if same_design(k, r, lengths)), None)
        if twin is None:
            kept.append(r)
        else:
            absorbed[_index(r)] = _index(twin)
    counts: dict = {}
    for target in absorbed.values():
        counts[target] = counts.get(target, 0) + 1
    return [r | {"merged": counts.get(_index(r), 0)} for r in records
            if _index(r) not in absorbed]


def visible(records: list[dict], lengths: list[str]) -> list[dict]:
    """The grid records a front shows (see the module's docstring); the raw end solves and
    the other keys pass through. A point that a verified design of its count beats on its own
    ε-problem (:func:`beater`; any record, any round, the ends) is shown with status
    ``local``: a verified design, but not the optimum of its problem."""
    grid = [r for r in records if not isinstance(_index(r), str)]
    other = [r for r in records if isinstance(_index(r), str)]
    out = []
    for n in sorted({r["count"] for r in grid}):
        mine = [r for r in grid if r["count"] == n]
        known = [r for r in mine if _ok(r)] + [r for r in other if r.get("count") == n and
                                              _ok(r)]
        for r in merge_identical(superseded(mine), lengths):
            if r.get("status") == "optimal" and _ok(r) and beater(r, known) is not None:
                r = r | {"status": LOCAL}
            out.append(r)
    return out + other


# --------------------------------------------------------------------------- gaps
@dataclass
class Gap:
    """Two neighbours of a count's front, in normalised (ratio, δ) distance, the turn of the
    slope between them, and the open ε interval still worth trying."""

    lower: dict
    upper: dict
    distance: float
    turn_deg: float | None          # None where a neighbour's slope is unknown
    lo: float
    hi: float


def _angle(slope, ratio_span: float, delta_span: float) -> float | None:
    if slope is None or not isinstance(slope, (int, float)) or not math.isfinite(slope):
        return None
    return math.degrees(math.atan(slope * ratio_span / delta_span))


def gaps(front: list[dict], tried: list[dict], settings: Refinement) -> list[Gap]:
    """The gaps of one count's front (non-dominated feasible records) to refine.

    ``tried``: every record of the count (any ε already solved: an ε inside a gap whose
    design landed on the gap's upper end shows the front jumps there; a failed one inside a
    gap leaves that gap alone).
    """
    pts = sorted(front, key=lambda r: (gain(r), r["delta"]))
    if len(pts) < 2:
        return []
    ratio = np.array([gain(p) for p in pts])
    delta = np.array([p["delta"] for p in pts])
    r_span, d_span = float(np.ptp(ratio)), float(np.ptp(delta))
    if r_span <= 0 or d_span <= 0:
        return []
    out = []
    for a, b in zip(pts, pts[1:]):
        dist = math.hypot((gain(b) - gain(a)) / r_span, (b["delta"] - a["delta"]) / d_span)
        ta, tb = (_angle(_slope(p), r_span, d_span) for p in (a, b))
        turn = abs(ta - tb) if ta is not None and tb is not None else None
        if not (dist > settings.max_gap or (turn is not None and turn > settings.max_turn_deg
                                            and dist > TURN_GAP_SHARE * settings.max_gap)):
            continue
        if settings.resolvable(a, b) < 2:
            continue            # the two neighbours are one point at the designer's scales
        lo, hi = gain(a), gain(b)
        inside = [t for t in tried if t.get("epsilon") is not None and lo < t["epsilon"] < hi]
        if any(not _ok(t) for t in inside):
            continue
        for t in inside:
            if gain(t) >= _less(gain(b)):
                hi = min(hi, t["epsilon"])          # the front jumps between lo and t's ε
        if (hi - lo) / r_span <= SETTLED_SHARE * settings.max_gap:
            continue
        out.append(Gap(a, b, dist, turn, lo, hi))
    return out


def share_out(want: list[int], worth, budget: int, cost: list[int] | None = None) -> list[int]:
    """Points per gap, one at a time to the gap of largest ``worth(i, given_i)`` (the first
    on a tie) among those that want more and whose ``cost`` (solves a point takes, default
    1) the budget still covers."""
    cost = cost or [1] * len(want)
    given = [0] * len(want)
    while True:
        open_ = [i for i in range(len(want)) if given[i] < want[i] and cost[i] <= budget]
        if not open_:
            return given
        i = max(open_, key=lambda i: (worth(i, given[i]), -i))
        given[i] += 1
        budget -= cost[i]


def allocate(found: list[Gap], budget: int, max_gap: float,
             settings: "Refinement | None" = None) -> list[int]:
    """New points per gap: each wants ceil(distance / max_gap) − 1 (at least one, at most
    what the resolution leaves room for); with too small a budget, one at a time to the gap
    whose share (distance / (given + 1)) is longest."""
    room = [settings.resolvable(g.lower, g.upper) - 1 if settings else math.inf for g in found]
    return share_out([max(1, min(math.ceil(g.distance / max_gap) - 1, r))
                      for g, r in zip(found, room)],
                     lambda i, k: found[i].distance / (k + 1), budget)


# --------------------------------------------------------------------------- a round's plan
def _non_dominated(rows: list[dict]) -> list[dict]:
    """The rows no other row dominates in (δ, ratio), in their order."""
    if not rows:
        return []
    mask = non_dominated(objectives([r["delta"] for r in rows], [gain(r) for r in rows]))
    return [r for r, keep in zip(rows, mask) if keep]


def beater(p: dict, known: list[dict]) -> dict | None:
    """The verified design of least δ in ``known`` (designs of p's count) that beats ``p`` on
    p's own problem, or None. An ε point's problem is the least δ at a gain of at least its ε:
    any design of less δ (by more than :data:`DOMINANCE_REL`) that reaches ε beats it. The
    least-ripple end's is the least δ at any gain; the best-gain end's the largest gain
    (then the least δ there)."""
    kind, eps = p.get("kind"), p.get("epsilon")
    less = [q for q in known if q is not p and _ok(q) and
            q["delta"] < p["delta"] * (1 - DOMINANCE_REL)]
    if kind == "least_ripple":
        found = less
    elif kind not in ("sweep", None):                # the best-gain end
        found = [q for q in known if q is not p and _ok(q) and gain(q) > _more(gain(p))] + \
            [q for q in less if gain(q) >= _less(gain(p))]
    elif eps is None:
        return None
    else:
        found = [q for q in less if gain(q) >= _less(eps)]
    return min(found, key=lambda q: (q["delta"], -gain(q)), default=None)


def dominated(front: list[dict]) -> list[tuple[dict, dict]]:
    """(point, its best dominator) for every point another one dominates by more than
    :data:`DOMINANCE_REL`; the dominator of least δ."""
    out = []
    for p in front:
        doms = [q for q in front if q is not p and
                ((q["delta"] < p["delta"] * (1 - DOMINANCE_REL) and gain(q) >= gain(p))
                 or (gain(q) > _more(gain(p)) and
                     q["delta"] <= p["delta"]))]
        if doms:
            out.append((p, min(doms, key=lambda q: (q["delta"], -gain(q)))))
    return out


def beaten(front: list[dict], known: list[dict]) -> list[tuple[dict, dict]]:
    """(point, the design to re-solve it from) for every point of ``front`` another point
    dominates (its best dominator) or a design of ``known`` beats on its own ε-problem
    (:func:`beater`)."""
    pairs = dict((_index(p), (p, q)) for p, q in dominated(front))
    for p in front:
        if _index(p) not in pairs:
            q = beater(p, known)
            if q is not None and q.get("design"):
                pairs[_index(p)] = (p, q)
    return list(pairs.values())


def plan(records: list[dict], lengths: list[str], settings: Refinement,
         first_index: int) -> list[Task]:
    """The next round's solves for one count, from its finished grid records (the rounds
    before it): re-solves of dominated points, then refined ε values (none when
    ``settings.enabled`` is false or the ``max_points`` budget is spent). Numbered from
    ``first_index``."""
    shown = merge_identical([r for r in superseded(records) if _ok(r)], lengths)
    attempted = {r.get("replaces") for r in records if r.get("replaces") is not None}
    tasks: list[Task] = []
    index = first_index
    for p, q in sorted(beaten(shown, [r for r in records if _ok(r)]),
                       key=lambda pq: _index(pq[0])):
        if _index(p) in attempted or p.get("epsilon") is None:
            continue
        tasks.append(Task(index, float(p["epsilon"]), q["design"], replaces=_index(p),
                          warm=q.get("warm")))
        index += 1
    if not settings.enabled:
        return tasks
    used = sum(1 for r in records if (r.get("round") or 0) >= 1 and r.get("replaces") is None)
    found = gaps(_non_dominated(shown), records, settings)
    given = allocate(found, settings.max_points - used, settings.max_gap, settings)
    new = []
    for g, k in zip(found, given):
        for j in range(1, k + 1):
            new.append((g.lo + (g.hi - g.lo) * j / (k + 1), g))
    for eps, g in sorted(new, key=lambda e: e[0]):
        # on one smooth stretch the lower neighbour's branch is the front; where the slope
        # turns, another branch may take over: the upper neighbour's is polished too
        turns = g.turn_deg is None or g.turn_deg > settings.max_turn_deg
        tasks.append(Task(index, float(eps), g.lower["design"],
                          also=[g.upper["design"]] if turns else [], warm=g.lower.get("warm")))
        index += 1
    return tasks


# --------------------------------------------------------------------------- every count at once
@dataclass
class CountTask:
    """A task of a hypervolume round, with the phase count it solves."""

    count: int
    task: Task


def _front_of_every_count(records: list[dict], lengths: list[str]) -> list[dict]:
    """The non-dominated rows of every count together (each count's rows as :func:`visible`
    shows them), by ratio."""
    return sorted(_non_dominated([r for r in visible(records, lengths)
                                  if not isinstance(_index(r), str) and _ok(r)]),
                  key=lambda r: (gain(r), r["delta"]))


def plan_hypervolume(records: list[dict], lengths: list[str], settings: Refinement,
                     least_index: int) -> list[CountTask]:
    """The next hypervolume round: new ε values where the front of every count together
    leaves more than ``settings.hypervolume_gap`` of the normalised hypervolume uncovered.

    Normalised so that the front spans [0, 1] in ratio and δ, two neighbours a, b leave the
    rectangle Δratio·Δδ between them to the staircase (about half of it above the true front
    where the front is straight). Splitting it into k + 1 parts divides that by (k + 1)², so
    a gap gets ⌈√(area / gap)⌉ − 1 new ε values (at least one), evenly in ratio, solved for
    b's count (from b; from a too where a is of the same count and the slope turns by more
    than ``max_turn_deg`` between them) and, where the front changes count in the gap, for
    a's count too (from a). The largest areas first, at most
    ``hypervolume_points`` solves over every hypervolume round. Gaps are left alone where a
    count's earlier ε inside failed, landed inside the gap (dominated there), or shows the
    front jumps (landed on b): the interval still open then shrinks to below the gap's area.

    ``records``: every count's grid records of the rounds before the one planned; points are
    numbered per count from one past its largest index (at least ``least_index``).
    """
    if not settings.enabled or settings.hypervolume_points <= 0:
        return []
    again = _beaten_again(records, lengths, least_index)
    used = sum(1 for r in records if (r.get("round") or 0) > MAX_ROUNDS and
               r.get("replaces") is None)
    budget = settings.hypervolume_points - used
    front = _front_of_every_count(records, lengths)
    if budget <= 0 or len(front) < 2:
        return again
    r_span = gain(front[-1]) - gain(front[0])
    d_span = max(r["delta"] for r in front) - min(r["delta"] for r in front)
    if r_span <= 0 or d_span <= 0:
        return []
    candidates = []                  # (area, [(count, lo, hi, start, also)])
    for a, b in zip(front, front[1:]):
        dx, dy = (gain(b) - gain(a)) / r_span, abs(b["delta"] - a["delta"]) / d_span
        if dx * dy <= settings.hypervolume_gap or settings.resolvable(a, b) < 2:
            continue
        counts = [b["count"]] + ([a["count"]] if a["count"] != b["count"] else [])
        ta, tb = (_angle(_slope(p), r_span, d_span) for p in (a, b))
        turns = ta is None or tb is None or abs(ta - tb) > settings.max_turn_deg
        jobs = []
        for n in counts:
            lo, hi = gain(a), gain(b)
            # an ε at a's own gain (to the dominance tolerance) is a's problem, not one
            # inside the gap: a's own ε lies just above its ratio when the ratio bound holds
            # to IPOPT's tolerance, below it
            inside = [t for t in records if t.get("count") == n and
                      t.get("epsilon") is not None and _more(lo) < t["epsilon"] < hi]
            if any(not _ok(t) or gain(t) < _less(gain(b))
                   for t in inside):
                continue
            for t in inside:
                hi = min(hi, t["epsilon"])          # the count's front jumps up to b
            if (hi - lo) / r_span * dy <= settings.hypervolume_gap:
                continue
            start = b if n == b["count"] else a
            also = [a["design"]] if n == b["count"] == a["count"] and turns else []
            jobs.append((n, lo, hi, start, also))
        if jobs:
            candidates.append((dx * dy, jobs, settings.resolvable(a, b)))
    given = share_out([max(1, min(math.ceil(math.sqrt(area / settings.hypervolume_gap)) - 1,
                                  room - 1)) for area, _, room in candidates],
                      lambda i, k: candidates[i][0] / (k + 1) ** 2, budget,
                      cost=[len(jobs) for _, jobs, _ in candidates])
    index = {}
    for r in records:
        if not isinstance(_index(r), str):
            index[r["count"]] = max(index.get(r["count"], least_index), _index(r) + 1)
    for t in again:
        index[t.count] = max(index.get(t.count, least_index), t.task.index + 1)
    out = []
    for (_, jobs, _), k in zip(candidates, given):
        for n, lo, hi, start, also in jobs:
            for j in range(1, k + 1):
                i = index.setdefault(n, least_index)
                index[n] = i + 1
                out.append(CountTask(n, Task(i, float(lo + (hi - lo) * j / (k + 1)),
                                             start["design"], also=also,
                                             warm=start.get("warm"))))
    return again + out


def _beaten_again(records: list[dict], lengths: list[str], least_index: int
                  ) -> list[CountTask]:
    """Re-solves, at the start of a hypervolume round, of every point a design found since
    beats on its own ε-problem and not re-solved yet (outside the round's budget)."""
    out = []
    for n in sorted({r["count"] for r in records if not isinstance(_index(r), str)}):
        mine = [r for r in records if r.get("count") == n and not isinstance(_index(r), str)]
        attempted = {r.get("replaces") for r in mine if r.get("replaces") is not None}
        shown = merge_identical([r for r in superseded(mine) if _ok(r)], lengths)
        index = max([least_index] + [_index(r) + 1 for r in mine])
        for p, q in sorted(beaten(shown, [r for r in mine if _ok(r)]),
                           key=lambda pq: _index(pq[0])):
            if _index(p) in attempted or p.get("epsilon") is None:
                continue
            out.append(CountTask(n, Task(index, float(p["epsilon"]), q["design"],
                                         replaces=_index(p), warm=q.get("warm"))))
            index += 1
    return out

"""A swept front as a pandas DataFrame, one row a design, with its non-dominated flags and
indicators; written as ``pareto.csv`` and ``pareto.json``."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from optdesign.fronts.axis import Axis
from optdesign.fronts.indicators import indicators, non_dominated, objectives
from optdesign.fronts.refine import VERIFIED
from optdesign.outputs.tabular import Tabular
from optdesign.outputs.units import stamped
from optdesign.quantities import known

#: leading columns of pareto.csv after the count, which the mechanism names (docs/contract.md
#: names the first nine: the four-bar's ``phases``, δ, ratio, its lengths, ``status``); the
#: mechanism's own design keys replace l0 .. l3 for other mechanisms
LEAD = ["delta", "ratio"]
#: after the lengths; the problem's criteria add their columns after the transmission angle
#: (the four-bar's ``pin_radius``)
TAIL = ["status", "min_transmission_angle_deg", "ratio_multiplier", "epsilon",
        "kind", "count_front", "non_dominated", "binding", "ipopt_status", "iterations",
        "time_s", "round", "start_from", "merged"]
#: the count under its generic name, and under the four-bar's name for every mechanism for one
#: release (a slotted lever's front has ``sections``, ``count`` and the deprecated ``phases``)
GENERIC_COUNT = "count"
DEPRECATED_COUNT = "phases"
#: quantities with columns of their own already: delta, ratio, min_transmission_angle_deg
ENVELOPE_QUANTITIES = ("ratio", "ripple", "transmission_angle")


def quantity_columns() -> list[str]:
    """Every other quantity (optdesign.quantities) is a column of its own, its worst over
    the listed eccentricities."""
    return [name for name in known() if name not in ENVELOPE_QUANTITIES]


def columns_of(count_name: str, lengths, criteria_columns=()) -> list[str]:
    """Every column of a front's table, in order: the count by its mechanism's name, δ, the
    ratio, the lengths, the status and the least transmission angle, the criteria's own
    columns, the rest of the sweep's, a column per other quantity, the generic count (and
    its deprecated name), the row's ε index."""
    tail = TAIL[:2] + list(criteria_columns) + TAIL[2:]
    generic = [GENERIC_COUNT] + ([DEPRECATED_COUNT] if count_name != DEPRECATED_COUNT else [])
    return [count_name] + LEAD + list(lengths) + tail + quantity_columns() + generic + ["index"]


def frame(records: list[dict], lengths: list[str], axis: Axis = Axis(),
          count_name: str = "phases", criteria_columns=()):
    """DataFrame of the grid-point records, sorted by count and ε (refined points among the
    others).

    ``count_front``: non-dominated among the feasible points of its own count;
    ``non_dominated``: non-dominated among the feasible points of every count. ``round``: 0
    for the uniform pass, r >= 1 for the r-th refinement round; ``start_from``: the start
    that gave the design; ``merged``: how many other ε points reached the same design (one
    row stands for them, :func:`optdesign.fronts.refine.visible`). ``count_name``: the
    mechanism's name of its count; ``criteria_columns``: the columns the problem's criteria
    give a design (the four-bar's ``pin_radius``).
    """
    import pandas as pd

    columns = columns_of(count_name, lengths, criteria_columns)
    rows = []
    for r in records:
        if isinstance(r["key"][1], str):          # the raw end-point solves: copied as points
            continue
        row = {k: r.get(k) for k in columns if k in r}
        row.update({k: r["count"] for k in (count_name, GENERIC_COUNT, DEPRECATED_COUNT)})
        row.update({k: r["design"].get(k) if r["design"] else None for k in lengths})
        values = (r.get("quantities") or {}).get("values", {})
        row.update({k: values.get(k) for k in quantity_columns()})
        row["index"] = r["key"][1]
        rows.append(row)
    df = pd.DataFrame(rows, columns=columns)
    df["count_front"] = False
    df["non_dominated"] = False
    if len(df):
        df = df.sort_values([GENERIC_COUNT, "epsilon", "index"], kind="stable").reset_index(
            drop=True)
        ok = df["status"].isin(VERIFIED)
        f = objectives(df.loc[ok, "delta"], gain(df.loc[ok], axis))
        df.loc[ok, "non_dominated"] = non_dominated(f)
        for n, group in df[ok].groupby(GENERIC_COUNT):
            g = objectives(group["delta"], gain(group, axis))
            df.loc[group.index, "count_front"] = non_dominated(g)
        if not axis.is_ratio:           # ε in the quantity's own units: the bound it held
            df["epsilon"] = axis.sign * df["epsilon"]
    for col in ("count_front", "non_dominated"):
        df[col] = df[col].astype(bool)
    return df


def gain(points, axis: Axis):
    """The front's second objective of every row, larger is better: the ratio, or sign times
    the quantity the front is swept against."""
    return axis.sign * points[axis.name].astype(float)


@dataclass
class ParetoResult(Tabular):
    """What ``optdesign pareto`` found: the points, their indicators, how the run was made."""

    points: object                        # pandas DataFrame (see :func:`frame`)
    indicators: dict                      # of the non-dominated set across every count
    per_count: dict = field(default_factory=dict)     # count -> indicators of its own front
    run: dict = field(default_factory=dict)
    ends: list[dict] = field(default_factory=list)    # the raw end-point solves
    #: the mechanism's name of its count (``phases``, ``sections``, ``freewheels``)
    count_name: str = "phases"
    #: the columns the problem's criteria add, with their units (the four-bar's pin radius)
    criteria_columns: dict = field(default_factory=dict)

    @property
    def axis(self) -> Axis:
        """What the ripple is traded against (the ratio unless ``pareto.against`` says)."""
        return Axis(self.run.get("against", "ratio"))

    @property
    def resolution(self) -> float:
        """The δ resolution the front was judged at (``pareto.resolution.delta``)."""
        return float((self.run.get("refine") or {}).get("delta_resolution", 1e-4))

    @property
    def front(self):
        """The designs non-dominated across every phase count, by the quantity the front is
        swept against (the ratio)."""
        return self.points[self.points["non_dominated"]].sort_values(self.axis.name)

    @property
    def knee(self):
        """The knee (best compromise) row of the overall front, or None."""
        k = self.indicators.get("knee")
        return None if k is None else self.points.loc[k]

    @property
    def knee_design(self) -> dict | None:
        """The knee's design (its lengths and count, as ``SolveResult.design`` holds one:
        what ``analyze``, ``plot_speeds`` and ``explore`` take), or None."""
        knee = self.knee
        return None if knee is None else self.design_of(knee)

    def design_of(self, row) -> dict:
        """The design of one row of :attr:`points` (a pandas row, or its index label): its
        lengths in mm and its count, by the mechanism's name."""
        if not hasattr(row, "to_dict"):
            row = self.points.loc[row]
        count = row.get(self.count_name, row.get(GENERIC_COUNT))
        return {self.count_name: int(count), **{k: float(row[k]) for k in self._lengths()}}

    def _lengths(self) -> list[str]:
        """The design's length columns (every column of the table not named by the front)."""
        known = set(columns_of(self.count_name, (), self.criteria_columns))
        return [c for c in self.points.columns if c not in known]

    def summary(self) -> str:
        ind = self.indicators
        n = ind.get("n_points", 0)
        if not n:
            return "no verified point on the front"
        hv = ind.get("hypervolume")
        return (f"{n} non-dominated designs" +
                (f", hypervolume {hv:.4f} (normalised, reference (1.1, 1.1))" if hv else ""))

    def to_frame(self):
        """Every point of the sweep (a copy of :attr:`points`)."""
        return self.points.copy()

    def shown_frame(self):
        """A notebook shows the front (the non-dominated designs), not every point."""
        return self.front

    def to_dict(self) -> dict:
        """pareto.json: the run, the indicators, the knee, every point and the raw ends, then
        ``schema_version`` and ``units``, which also give the unit of every pareto.csv
        column (the design columns in mm)."""
        df = self.points.replace({np.nan: None})
        lengths = self._lengths()
        # a design holds the lengths and the count (by its mechanism's name)
        counts = {k for end in self.ends for k in (end.get("design") or {})} - set(lengths)
        count_units = {k: "- (count)" for k in
                       {self.count_name, GENERIC_COUNT, DEPRECATED_COUNT} | counts}
        return stamped({"run": self.run, "indicators": self.indicators,
                        "per_count": {str(k): v for k, v in self.per_count.items()},
                        "knee": None if self.knee is None else _plain(self.knee.to_dict()),
                        "points": [_plain(r) for r in df.to_dict(orient="records")],
                        "ends": [{k: v for k, v in end.items() if k not in JOURNAL_ONLY}
                                 for end in self.ends]},
                       count_units | dict(self.criteria_columns) | {k: "mm" for k in lengths}
                       | self._axis_units())

    def _axis_units(self) -> dict:
        """On a front against another quantity than the ratio, ε is a bound on it."""
        axis = self.axis
        if axis.is_ratio:
            return {}
        return {"epsilon": f"{axis.unit} (the bound on {axis.name} of the point's solve)",
                "gain": f"{axis.unit} ({'+' if axis.sign > 0 else '-'}{axis.name}: the "
                        f"front's second objective, larger is better)",
                "gain_multiplier": f"1/{axis.unit} (d delta / d gain)"}


#: the keys of a journal record that stay in ``points.jsonl``: ``warm``, the primal-dual
#: optimum a neighbour's polish starts from (:meth:`optdesign.solver.PhaseSolver.solve_from`)
JOURNAL_ONLY = ("warm",)


def _plain(row: dict) -> dict:
    out = {}
    for k, v in row.items():
        if isinstance(v, np.generic):
            v = v.item()
        if isinstance(v, float) and not np.isfinite(v):
            v = None
        out[k] = v
    return out


def evaluate(points, axis: Axis = Axis(), flat_below: float | None = None,
             at_rest: float | None = None) -> tuple[dict, dict]:
    """Indicators of the overall front (knee as a row label of ``points``) and per count;
    a front whose δ spans less than ``flat_below`` is flat, its knee the largest-gain end;
    a design of δ ``at_rest`` (its output at rest once a turn) is not the knee where
    another can be (:func:`~optdesign.fronts.indicators.indicators`)."""
    ok = points[points["status"].isin(VERIFIED)]
    named = {"name": axis.name, "sign": axis.sign, "flat_below": flat_below,
             "at_rest": at_rest}
    overall = indicators(ok["delta"], gain(ok, axis), **named)
    if overall["knee"] is not None:
        overall["knee"] = int(ok.index[overall["knee"]])
    per_count = {}
    for n, group in ok.groupby(GENERIC_COUNT):
        ind = indicators(group["delta"], gain(group, axis), **named)
        if ind["knee"] is not None:
            ind["knee"] = int(group.index[ind["knee"]])
        per_count[int(n)] = ind
    return overall, per_count

"""The Pareto front of ripple against a second quantity (the ratio unless ``pareto: {against:}``
names another): ε-constraint sweep (sweep), journal (store),
filtering and indicators (indicators, front), the report (report).

A notebook calls :func:`optdesign.api.pareto` (``from optdesign import pareto``); this package
is its engine."""
from optdesign.fronts.front import ParetoResult
from optdesign.fronts.indicators import hypervolume_2d, knee, non_dominated, spacing
from optdesign.fronts.sweep import sweep

__all__ = ["ParetoResult", "hypervolume_2d", "knee", "non_dominated", "spacing", "sweep"]

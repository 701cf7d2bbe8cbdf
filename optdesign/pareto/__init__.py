"""The Pareto front of ripple against ratio: ε-constraint sweep (sweep), journal (store),
filtering and indicators (indicators, front), the report (report)."""
from .front import ParetoResult
from .indicators import hypervolume_2d, knee, non_dominated, spacing
from .sweep import sweep

__all__ = ["ParetoResult", "hypervolume_2d", "knee", "non_dominated", "spacing", "sweep"]

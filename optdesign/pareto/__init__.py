"""The Pareto front of ripple against ratio: ε-constraint sweep (sweep), journal (store),
filtering and indicators (indicators, front), the report (report).

The package is also the API's function: ``from optdesign import pareto; pareto(problem)``
calls :func:`optdesign.api.pareto`."""
from .front import ParetoResult
from .indicators import hypervolume_2d, knee, non_dominated, spacing
from .sweep import sweep

__all__ = ["ParetoResult", "hypervolume_2d", "knee", "non_dominated", "spacing", "sweep"]

from ..callable_package import make_callable  # noqa: E402

make_callable(__name__, "pareto")

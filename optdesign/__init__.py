"""optdesign: sizing the converting linkages of pulse continuously variable transmissions.

The Python API (docs/api.md)::

    from optdesign import load_problem, analyze, solve, pareto

Heavy modules (CasADi, pandas, matplotlib, dask) are imported only when a function needs them.
"""
from importlib import import_module

__version__ = "0.1.0"
__all__ = ["Options", "__version__", "analyze", "explore", "load_options", "load_problem",
           "pareto", "plot_front", "plot_mechanism", "plot_speeds", "sensitivities", "solve"]


def __getattr__(name: str):
    if name in __all__ and name != "__version__" or name == "as_problem":
        return getattr(import_module("optdesign.api"), name)
    raise AttributeError(f"module 'optdesign' has no attribute {name!r}")

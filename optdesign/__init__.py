"""optdesign: sizing the converting linkages of pulse continuously variable transmissions.

The Python API (docs/api.md)::

    from optdesign import load_problem, analyze, solve, pareto

Heavy modules (CasADi, pandas, matplotlib, dask) are imported only when a function needs them.
"""
from importlib import import_module

__version__ = "0.1.0"
__all__ = ["__version__", "analyze", "load_problem", "pareto", "plot_front", "plot_mechanism",
           "plot_speeds", "sensitivities", "solve"]


def __getattr__(name: str):
    if name in ("load_problem", "analyze", "as_problem", "plot_front", "plot_mechanism",
                "plot_speeds", "sensitivities"):
        return getattr(import_module(".api", __name__), name)
    if name in ("solve", "pareto"):            # the packages, callable as the API's functions
        return import_module(f".{name}", __name__)
    raise AttributeError(f"module 'optdesign' has no attribute {name!r}")

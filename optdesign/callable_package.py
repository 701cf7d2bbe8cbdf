"""``from optdesign import solve, pareto`` gives the API's functions although
``optdesign.solve`` and ``optdesign.pareto`` are packages too: each such package module is made
callable, its call being the function of :mod:`optdesign.api` of the same name, while its
modules (``optdesign.solve.driver``, ...) stay where they are."""
from __future__ import annotations

import sys
import types
from importlib import import_module


def make_callable(package: str, function: str) -> None:
    """Calling the module ``package`` calls ``optdesign.api.<function>``."""

    class CallablePackage(types.ModuleType):
        def __call__(self, *args, **kwargs):
            return getattr(import_module("optdesign.api"), function)(*args, **kwargs)

    CallablePackage.__call__.__doc__ = f"optdesign.api.{function} (see docs/api.md)"
    sys.modules[package].__class__ = CallablePackage

"""The registry of converting mechanisms: one module each, found by the name a problem file uses."""
from __future__ import annotations

from importlib import import_module

from optdesign.errors import ProblemError
from optdesign.mechanisms.base import Mechanism, OptionSpec, VariableSpec

#: name -> "module:Class"; a new mechanism is one module and one line here.
REGISTRY: dict[str, str] = {
    "fourbar_converter": "optdesign.mechanisms.fourbar_converter:FourBarConverter",
    "pulse_reducer": "optdesign.mechanisms.pulse_reducer:PulseReducer",
    "slotted_lever": "optdesign.mechanisms.slotted_lever:SlottedLever",
}

_instances: dict[str, Mechanism] = {}


def known() -> list[str]:
    return sorted(REGISTRY)


def get_mechanism(name: str) -> Mechanism:
    """The mechanism registered as ``name``; an unknown name lists the known ones."""
    if name not in REGISTRY:
        raise ProblemError(f"unknown mechanism {name!r}; known: {', '.join(known())}")
    if name not in _instances:
        module, cls = REGISTRY[name].split(":")
        _instances[name] = getattr(import_module(module), cls)()
    return _instances[name]


__all__ = ["REGISTRY", "Mechanism", "OptionSpec", "VariableSpec",
           "get_mechanism", "known"]

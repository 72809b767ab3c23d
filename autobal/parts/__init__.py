"""The optional parts of a scene: one module each, ``autobal/parts/<key>.py``.

A part module defines ``SCHEMA`` (the pydantic schema of the top-level section ``<key>``), ``DESCRIPTION``
(one line for the schema reference) and, where the physics takes one, ``adapt(section)``: the validated
section to the SI parameter object of :mod:`autobal.models`.  The schemas are derived from those parameter
objects (:mod:`autobal.parts.derived`); the device's is built by :func:`autobal.parts.device.device_model`
(with or without its ``dynamics`` section).

:data:`MODULES` is the one list kept by hand, in the scene's order; a module is imported only when a scene
names its part.
"""

from __future__ import annotations

import importlib
from types import ModuleType

MODULES = {
    "device": "autobal.parts.device",
    "liquid_balancer": "autobal.parts.liquid_balancer",
    "rotor": "autobal.parts.rotor",
    "ross_rotor": "autobal.parts.ross_rotor",
    "executor": "autobal.parts.executor",
}


def module(key: str) -> ModuleType:
    """The module of part ``key`` (imported now if it was not)."""
    return importlib.import_module(MODULES[key])

"""Scene part ``device.dynamics`` (Pavlenko 2014, §2.4, §2.6, App. A/B dynamic data): its schema, built only
when a scene has the section; its adapter to :class:`autobal.models.dynamics.DynamicData` is
:func:`autobal.parts.device.dynamic_data`.

``device.dynamics`` holds the masses, stiffnesses, damping, chamber volumes and bulk modulus of
the rotor - balancing device - regulator system; ``analyses.frequency``, ``analyses.stability``,
``analyses.transient`` and ``analyses.design`` are built on it.  Its schema is derived from
:class:`~autobal.models.dynamics.DynamicData` (:mod:`autobal.parts.derived`), where each parameter is declared
with its scene key, unit, meaning and default; the regulator's parameters form the sub-section ``regulator``.
The defaults taken from other sections (rotor damping, operating speed, seat area) are filled in by the adapter.
"""

from __future__ import annotations

from dataclasses import fields
from typing import Literal

from autobal.models.dynamics import LONG_NAMES, DynamicData
from autobal.parts.derived import Group, schema
from autobal.schema import Strict

Dynamics = schema(DynamicData, "Dynamics", base=Strict, doc="Dynamic data of the device (``device.dynamics``), "
                  "Pavlenko (2014), App. A / App. B.",
                  groups=(Group("regulator", "RegulatorDynamics", "stem of the pressure-drop regulator and its two "
                                "chambers, Pavlenko (2014), App. A; needed when the device has a regulator",
                                optional=True),))
RegulatorDynamics = Dynamics.model_fields["regulator"].annotation.__args__[0]

# scenario key -> unit kind of each dynamic parameter a stability map may scan (models/dynamics.LONG_NAMES)
_KINDS = {f.name: f.metadata["kind"] for f in fields(DynamicData)}
PARAMETERS = {long: _KINDS[short] for long, short in LONG_NAMES.items()}
ParameterName = Literal[tuple(PARAMETERS)]  # type: ignore[valid-type]
# the dynamic models of the device an analysis can name (analysis/numerics/linearize.py)
ModelName = Literal["nonlinear", "nonlinear_chain", "program", "thesis", "consistent"]

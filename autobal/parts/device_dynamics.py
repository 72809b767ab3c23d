"""Scene part ``device.dynamics`` (Pavlenko 2014, §2.4, §2.6, App. A/B dynamic data): its schema, built only
when a scene has the section; its adapter to :class:`autobal.models.dynamics.DynamicData` is
:func:`autobal.parts.device.dynamic_data`.

``device.dynamics`` holds the masses, stiffnesses, damping, chamber volumes and bulk modulus of
the rotor - balancing device - regulator system; ``analyses.frequency``, ``analyses.stability``,
``analyses.transient`` and ``analyses.design`` are built on it.  Quantities carry units and are converted
to SI on loading.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from autobal.models.dynamics import LONG_NAMES
from autobal.schema import Positive, Strict
from autobal.units import AngularSpeed, Area, DampingOrZero, Mass, Stiffness, Volume, quantity

Damping = quantity("damping")
BulkModulus = quantity("bulk modulus")


class RegulatorDynamics(Strict):
    """Stem of the pressure-drop regulator and its two chambers (Pavlenko (2014), App. A)."""

    stem_mass: Mass = Field(description="m0")
    spring_stiffness: Stiffness = Field(description="k_reg")
    stem_damping: DampingOrZero = Field(0.0, description="c_x (the source: 0)")
    valve_chamber_volume: Volume = Field(description="V_cam")
    membrane_chamber_volume: Volume = Field(description="V_m")
    seat_area: Area | None = Field(None, description="s_c; default pi d_c^2 / 4 from regulator.valve.seat_diameter")


class Dynamics(Strict):
    """Dynamic data of the device (``device.dynamics``), Pavlenko (2014), App. A / App. B."""

    rotor_mass: Mass = Field(description="m_p")
    pushoff_stiffness: Stiffness = Field(description="k_pr; preload deflection F_pr/k_pr + z0")
    rotor_damping: DampingOrZero | None = Field(
        None, description="c_z (0: undamped); default the squeeze film, Pavlenko (2014), App. A")
    bulk_modulus: BulkModulus = Field(description="E of the barrier medium (gas: the source's 1.42e5 Pa)")
    disc_chamber_volume: Volume = Field(description="V2, chamber before the face throttle")
    cavity_volume: Volume = Field(description="V3, cavity behind the disc")
    regulator: RegulatorDynamics | None = Field(None, description="needed when the device has a regulator")
    forcing_amplitude: Positive = Field(0.2, description="delta psi_1a, amplitude of the harmonic discharge pressure")
    operating_speed: AngularSpeed | None = Field(None, description="omega0; default the impeller speed")


# scenario key -> unit kind of each dynamic parameter a stability map may scan (models/dynamics.LONG_NAMES)
PARAMETERS = {
    "rotor_mass": "mass", "pushoff_stiffness": "stiffness", "rotor_damping": "damping", "bulk_modulus": "bulk modulus",
    "disc_chamber_volume": "volume", "cavity_volume": "volume", "stem_mass": "mass", "spring_stiffness": "stiffness",
    "stem_damping": "damping", "valve_chamber_volume": "volume", "membrane_chamber_volume": "volume",
    "seat_area": "area",
}
assert set(PARAMETERS) == set(LONG_NAMES)
ParameterName = Literal[tuple(PARAMETERS)]  # type: ignore[valid-type]
# the dynamic models of the device an analysis can name (analysis/linearize.py)
ModelName = Literal["nonlinear", "nonlinear_chain", "program", "thesis", "consistent"]

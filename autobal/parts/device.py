"""Scene part ``device``: the axial balancing device (Pavlenko (2014), ch. 2), its schema and its adapter to
:class:`autobal.models.device.DeviceParams` (SI).

The schema of ``device.dynamics`` is in :mod:`autobal.parts.device_dynamics`, built only when a scene has
that section (:func:`device_model`).  The physics (:mod:`autobal.models`) never sees a schema object or a
YAML path: :func:`adapt` is where the section becomes plain frozen dataclasses in SI, with the scene's
defaults filled in, and where a missing or inconsistent section is reported with its YAML path.
"""

from __future__ import annotations

import dataclasses
import math
from functools import cache

from pydantic import Field, create_model

from autobal.errors import ScenarioError
from autobal.models import device as dv
from autobal.models.dynamics import DynamicData, squeeze_damping
from autobal.parts.derived import SCENE_CHECKS, schema, to_params
from autobal.schema import Strict

DESCRIPTION = "the axial balancing device (statics, dynamics, Monte Carlo, fits)"
DYNAMICS_DESCRIPTION = "masses, springs, volumes for the frequency, stability and transient analyses"


# The schema of each section is derived from the SI parameter dataclass of autobal.models.device
# (autobal.parts.derived), the one declaration of each parameter; the checks across its fields are its
# ``__post_init__``, and a scene's own rules are below.


def _drain_below_nominal(op: dv.Operating) -> None:
    """A scene's drain pressure is below its nominal discharge pressure (the model itself solves a drain above:
    the face pressed shut, nothing balanced)."""
    if op.drain_pressure >= op.nominal_pressure:
        raise ValueError(f"drain_pressure: {op.drain_pressure / 1e6:g} MPa is not below the nominal discharge "
                         f"pressure {op.nominal_pressure / 1e6:g} MPa; the device leaks from the discharge to "
                         "the drain (above it the face is pressed shut and nothing is balanced)")


SCENE_CHECKS[dv.Operating] = _drain_below_nominal


@cache
def device_model(dynamics: bool = True) -> type[Strict]:
    """The ``Device`` model, with the schema of its ``dynamics`` section or (False) without it.

    Parameters
    ----------
    dynamics : bool
        Build the schema of ``device.dynamics`` (imports autobal.parts.device_dynamics).

    Returns
    -------
    type
        A pydantic model named ``Device``.
    """
    section = None
    if dynamics:
        from autobal.parts.device_dynamics import Dynamics

        section = Dynamics | None
    return create_model("Device", __base__=schema(dv.DeviceParams), __module__=__name__,
                        __doc__="The axial balancing device, Pavlenko (2014), ch. 2.",
                        dynamics=(section, Field(None, description=DYNAMICS_DESCRIPTION)))



def adapt(d) -> dv.DeviceParams:
    """The scene's ``device`` section as :class:`autobal.models.device.DeviceParams` (SI).

    Parameters
    ----------
    d : Device
        The validated section.

    Returns
    -------
    DeviceParams
        With ``dynamics`` when the section has ``device.dynamics``.
    """
    params = to_params(d)
    if d.dynamics is None:
        return params
    return dataclasses.replace(params, dynamics=dynamic_data(d, params))


def dynamic_data(d, params: dv.DeviceParams) -> DynamicData:
    """The ``device.dynamics`` section with its defaults filled in (SI).

    Defaults: rotor damping the face's squeeze film (:func:`autobal.models.dynamics.squeeze_damping`),
    operating speed the impeller's, seat area pi d_c^2 / 4.

    Parameters
    ----------
    d : Device
        The validated ``device`` section (with ``dynamics``).
    params : DeviceParams
        The same device as parameters.

    Returns
    -------
    DynamicData
    """
    dyn = d.dynamics
    if dyn is None:
        raise ScenarioError("device.dynamics: the dynamic analyses need a dynamics section")
    if (d.regulator is None) != (dyn.regulator is None):
        raise ScenarioError("device.dynamics.regulator: give it exactly when the device has a regulator "
                            "(stem_mass, spring_stiffness, valve_chamber_volume, membrane_chamber_volume)")
    filled = {"p_n": params.fluid.normal_pressure}
    if dyn.rotor_damping is None:
        face = params.disc.face
        filled["c_z"] = squeeze_damping(params.fluid.viscosity, dv.face_area(face), face.base_gap)
    if dyn.operating_speed is None and params.operating.impeller is not None:
        filled["omega0"] = params.operating.impeller.speed
    if dyn.regulator is not None:
        reg = params.regulator
        filled["s_m"] = reg.membrane_area
        if dyn.regulator.seat_area is None:
            filled["s_c"] = math.pi * reg.valve.seat_diameter**2 / 4
    return to_params(dyn, **filled)


def dynamic_device(scn) -> dv.DeviceParams:
    """The scene's device with its dynamic data, for the frequency, stability and transient analyses.

    Raises
    ------
    ScenarioError
        When the scene has no ``device`` or no ``device.dynamics``.
    """
    if scn.device is None or scn.device.dynamics is None:
        raise ScenarioError(f"{scn.name}: the dynamic analyses need device.dynamics (masses, springs, volumes)")
    return adapt(scn.device)


def design(d) -> dv.DeviceDesign:
    """The dimensionless groups of the scene's ``device`` section (:func:`autobal.models.device.design`)."""
    return dv.design(adapt(d))

"""Scenario schema of a rotor given as ROSS elements (optional top-level part ``ross_rotor:``) and of its
analysis ``ross_spinup``: the minimum-peak spin-up of the rotor reduced to its modes, through two or
more critical speeds (:mod:`autobal.ocp.modal`).

Needs the optional ROSS package (``pip install -e '.[ross]'``); a scene naming it without the package
installed exits 2 with one line naming the extra.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, model_validator

from autobal.schema import Strict
from autobal.units import AngularSpeed, Density, Length, Pressure, quantity

Mass = quantity("mass")
Inertia = quantity("moment of inertia")
StiffnessOrZero = quantity("stiffness", "nonnegative")
DampingOrZero = quantity("damping", "nonnegative")
Time = quantity("time")
TimeOrZero = quantity("time", "nonnegative")
AngularAcceleration = quantity("angular acceleration")
SpeedOrZero = quantity("angular speed", "nonnegative")
LengthOrZero = quantity("length", "nonnegative")
Node = Annotated[int, Field(ge=0, le=10_000)]
EXAMPLES = ("rotor_example", "compressor_example", "rotor_example_with_damping", "rotor_example_6dof",
            "coaxrotor_example")


class RossMaterial(Strict):
    """Shaft material (ROSS ``Material``); the defaults are ROSS's steel."""

    density: Density = Field(7810.0, description="rho")
    young_modulus: Pressure = Field(211e9, description="E")
    shear_modulus: Pressure = Field(81.2e9, description="G_s")


class RossShaft(Strict):
    """One Timoshenko shaft element (ROSS ``ShaftElement``, shear, rotary inertia and gyroscopic terms)."""

    length: Length = Field(description="element length L")
    outer_diameter: Length = Field(description="odl")
    inner_diameter: LengthOrZero = Field(0.0, description="idl (0 for a solid shaft)")
    count: Annotated[int, Field(ge=1, le=200)] = Field(1, description="this element repeated, 1 to 200 times")


class RossDisk(Strict):
    """A rigid disk (ROSS ``DiskElement``) at a node."""

    node: Node = Field(description="node number (0 at the left end)")
    mass: Mass = Field(description="m")
    diametral_inertia: Inertia = Field(description="I_d")
    polar_inertia: Inertia = Field(description="I_p")


class RossBearing(Strict):
    """A linear bearing (ROSS ``BearingElement``) with constant coefficients; y defaults to x."""

    node: Node = Field(description="node number")
    kxx: StiffnessOrZero = Field(description="direct stiffness in x")
    kyy: StiffnessOrZero | None = Field(None, description="direct stiffness in y (default kxx)")
    kxy: StiffnessOrZero = Field(0.0, description="cross-coupled stiffness")
    kyx: StiffnessOrZero = Field(0.0, description="cross-coupled stiffness")
    cxx: DampingOrZero = Field(0.0, description="direct damping in x")
    cyy: DampingOrZero | None = Field(None, description="direct damping in y (default cxx)")


class RossUnbalance(Strict):
    """Unbalance m e at a node, with its phase."""

    node: Node = Field(description="node number")
    magnitude: Annotated[float, Field(gt=0, le=1e3)] = Field(description="m e, kg m")
    phase: Annotated[float, Field(ge=-360, le=360)] = Field(0.0, description="phase beta, degrees")


class RossRotor(Strict):
    """A rotor as ROSS elements (shaft, disks, bearings) or a ROSS example rotor by name, with its unbalance."""

    example: Literal[EXAMPLES] | None = Field(None, description="a ROSS example rotor instead of the elements")
    material: RossMaterial = Field(RossMaterial(), description="shaft material")
    shaft: Annotated[list[RossShaft], Field(max_length=200)] = Field([], description="shaft elements, left to right")
    disks: Annotated[list[RossDisk], Field(max_length=200)] = Field([], description="rigid disks")
    bearings: Annotated[list[RossBearing], Field(max_length=200)] = Field([], description="bearings")
    unbalance: Annotated[list[RossUnbalance], Field(min_length=1, max_length=200)] = Field(
        description="unbalances m e at nodes")

    @model_validator(mode="after")
    def _elements_or_example(self):
        if self.example is None and not (self.shaft and self.bearings):
            raise ValueError("give shaft elements and bearings, or a ROSS example rotor by name (example)")
        if self.example is not None and (self.shaft or self.disks or self.bearings):
            raise ValueError("give either the elements or example, not both")
        if self.example is None:
            nodes = sum(s.count for s in self.shaft) + 1
            for what, items in (("disks", self.disks), ("bearings", self.bearings), ("unbalance", self.unbalance)):
                for i, it in enumerate(items):
                    if it.node >= nodes:
                        raise ValueError(f"{what}.{i}.node: {it.node} is not a node of the shaft (0 to {nodes - 1})")
        return self


class RossSpinup(Strict):
    """Minimum-peak spin-up of the ROSS rotor reduced to its modes, posed as a drive is specified (as the
    Jeffcott ``spinup``): reach ``final_speed`` by the deadline ``horizon``, hold it over ``settling_time``
    (the peak counts over the whole window), never exceed ``max_speed``, |alpha| <= ``max_acceleration``."""

    start_speed: SpeedOrZero = Field(description="speed at t = 0 (steady state there)")
    final_speed: AngularSpeed = Field(description="reached by the deadline")
    horizon: Time = Field(description="the deadline")
    max_acceleration: AngularAcceleration = Field(description="bound on |alpha|")
    settling_time: TimeOrZero = Field(0.0, description="held at final_speed after the deadline")
    max_speed: AngularSpeed | None = Field(None, description="speed cap")
    nodes: Annotated[list[Node], Field(min_length=1, max_length=50)] = Field(
        description="nodes whose lateral deflection sqrt(x^2 + y^2) counts (the peak is the largest)")
    mode_cutoff: Annotated[float, Field(ge=1.0, le=10.0)] = Field(
        1.5, description="modes with natural frequency up to mode_cutoff x final_speed are kept, 1 to 10")
    gyroscopic_tolerance: Annotated[float, Field(ge=0, le=1)] = Field(
        1e-3, description="the gyroscopic terms are kept when they move a critical speed by more than this fraction")
    intervals: Annotated[int, Field(ge=4, le=2000)] = Field(160, description="control intervals over the horizon")
    degree: Annotated[int, Field(ge=1, le=9)] = Field(3, description="Radau collocation degree, 1 to 9")
    max_iterations: Annotated[int, Field(ge=1, le=100000)] = Field(1000, description="IPOPT iterations per solve")
    validate_with_ross: bool = Field(True, description="compare the reduced critical speeds with ROSS's own")

    @model_validator(mode="after")
    def _consistent(self):
        if self.max_speed is not None and self.max_speed < max(self.start_speed, self.final_speed):
            raise ValueError("max_speed must not be below start_speed and final_speed")
        if self.final_speed - self.start_speed > self.max_acceleration * self.horizon:
            raise ValueError("max_acceleration x horizon is less than the speed change: the deadline cannot be met")
        return self

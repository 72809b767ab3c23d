"""Scene part ``ross_rotor``: a rotor given as ROSS elements or a ROSS example rotor, its schema and its
adapter to :class:`autobal.models.ross_rotor.RossRotorSpec` (SI); ``analyses.ross_spinup`` is built on it.

Needs the optional ROSS package (``pip install -e '.[ross]'``); a scene naming it without the package
installed exits 2 with one line naming the extra.
"""

from __future__ import annotations

import math
from typing import Annotated, Literal

from pydantic import Field, model_validator

from autobal.models import ross_rotor as rr
from autobal.schema import Strict
from autobal.units import DampingOrZero, Density, Inertia, Length, LengthOrZero, Mass, Pressure, quantity

StiffnessOrZero = quantity("stiffness", "nonnegative")
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


SCHEMA = RossRotor
DESCRIPTION = "a rotor as ROSS elements or a ROSS example rotor (the ross extra)"


def adapt(r: RossRotor):
    """The scene's ``ross_rotor`` section as :class:`autobal.models.ross_rotor.RossRotorSpec` (SI) and its
    unbalances.

    Parameters
    ----------
    r : RossRotor
        The validated section (phases in degrees).

    Returns
    -------
    (RossRotorSpec, tuple of Unbalance)
        Elements in SI; unbalance m e in kg m, phase in rad.
    """
    ub = tuple(rr.Unbalance(u.node, u.magnitude, math.radians(u.phase)) for u in r.unbalance)
    if r.example is not None:
        return rr.RossRotorSpec(example=r.example), ub
    m = r.material
    shaft = tuple(rr.Shaft(s.length, s.inner_diameter, s.outer_diameter) for s in r.shaft for _ in range(s.count))
    disks = tuple(rr.Disk(d.node, d.mass, d.diametral_inertia, d.polar_inertia) for d in r.disks)
    brgs = tuple(rr.Bearing(b.node, b.kxx, b.kxx if b.kyy is None else b.kyy, b.cxx, b.cxx if b.cyy is None else b.cyy,
                            b.kxy, b.kyx) for b in r.bearings)
    return rr.RossRotorSpec(shaft=shaft, disks=disks, bearings=brgs,
                            material=rr.Material(m.density, m.young_modulus, m.shear_modulus)), ub

"""Scene part ``ross_rotor``: a rotor given as ROSS elements or a ROSS example rotor, its schema and its
adapter to :class:`autobal.models.ross_rotor.RossRotorSpec` (SI); ``analyses.ross_spinup`` is built on it.

The schema of each element (material, shaft element, disk, bearing, unbalance) is derived from its dataclass
of :mod:`autobal.models.ross_rotor` (:mod:`autobal.parts.derived`), where each parameter is declared with its
unit, meaning, bounds and default.  Written here by hand: the section itself (the element lists, their
lengths, the example rotor by name, the node checks), a shaft element's ``count`` (repetitions), an
unbalance's phase in degrees (the model's is in rad), and the drive (the Jeffcott rotor's drive limits and the
drive's own polar inertia), which the spin-up analyses read.

Needs the optional ROSS package (``pip install -e '.[ross]'``); a scene naming it without the package
installed exits 2 with one line naming the extra.
"""

from __future__ import annotations

import math
from typing import Annotated, Literal

from pydantic import Field, model_validator

from autobal.models import ross_rotor as rr
from autobal.parts.derived import schema, to_params
from autobal.parts.rotor import DriveLimits
from autobal.schema import Strict
from autobal.units import quantity

Node = Annotated[int, Field(**rr.NODES)]
EXAMPLES = ("rotor_example", "compressor_example", "rotor_example_with_damping", "rotor_example_6dof",
            "coaxrotor_example")


class _Shaft(Strict):
    """One Timoshenko shaft element (ROSS ``ShaftElement``, shear, rotary inertia and gyroscopic terms)."""

    count: Annotated[int, Field(ge=1, le=200)] = Field(1, description="this element repeated, 1 to 200 times")


class _Unbalance(Strict):
    """Unbalance m e at a node, with its phase."""

    phase: Annotated[float, Field(ge=-360, le=360)] = Field(0.0, description="phase beta, degrees")


RossMaterial = schema(rr.Material, "RossMaterial", base=Strict)
RossShaft = schema(rr.Shaft, "RossShaft", base=_Shaft)
RossDisk = schema(rr.Disk, "RossDisk", base=Strict, doc="A rigid disk (ROSS ``DiskElement``) at a node.")
RossBearing = schema(rr.Bearing, "RossBearing", base=Strict, doc="A linear bearing (ROSS ``BearingElement``) "
                     "with constant coefficients; y defaults to x.")
RossUnbalance = schema(rr.Unbalance, "RossUnbalance", base=_Unbalance)


class RossDrive(DriveLimits):
    """The drive of a ROSS rotor, as the Jeffcott rotor's (torque, power and motor limits, braking): the torque
    it needs is J alpha, J the rotor's polar inertia (from ROSS's mass matrix) and the drive's own."""

    polar_inertia: quantity("moment of inertia", "nonnegative") = Field(
        0.0, description="the drive's own polar inertia (motor rotor, coupling) beside the rotor's, kg m^2")


class RossRotor(Strict):
    """A rotor as ROSS elements (shaft, disks, bearings) or a ROSS example rotor by name, with its unbalance."""

    example: Literal[EXAMPLES] | None = Field(None, description="a ROSS example rotor instead of the elements")
    material: RossMaterial = Field(RossMaterial(), description="shaft material")
    shaft: Annotated[list[RossShaft], Field(max_length=200)] = Field([], description="shaft elements, left to right")
    disks: Annotated[list[RossDisk], Field(max_length=200)] = Field([], description="rigid disks")
    bearings: Annotated[list[RossBearing], Field(max_length=200)] = Field([], description="bearings")
    unbalance: Annotated[list[RossUnbalance], Field(min_length=1, max_length=200)] = Field(
        description="unbalances m e at nodes")
    drive: RossDrive | None = Field(None, description="the drive's inertia and limits (the spin-up analyses)")

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
    ub = tuple(to_params(u, phase=math.radians(u.phase)) for u in r.unbalance)
    if r.example is not None:
        return rr.RossRotorSpec(example=r.example), ub
    shaft = tuple(to_params(s) for s in r.shaft for _ in range(s.count))
    brgs = tuple(to_params(b, kyy=b.kxx if b.kyy is None else b.kyy, cyy=b.cxx if b.cyy is None else b.cyy)
                 for b in r.bearings)
    return rr.RossRotorSpec(shaft=shaft, disks=tuple(to_params(d) for d in r.disks), bearings=brgs,
                            material=to_params(r.material)), ub

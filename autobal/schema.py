"""Building blocks of scenario schemas: strict models (unknown keys refused) and common types.

Each analysis keeps its own schema classes in its own module, built from these blocks and the
quantity types of :mod:`autobal.units`; :mod:`autobal.scenario` assembles them.
"""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, model_validator

# Dimensionless numbers: finite (every model refuses inf and nan) and at most 1e6 in magnitude, far beyond
# any ratio, coefficient or weight of the sources; tighter bounds where physics gives them (PressureRatio).
BIG = 1e6
Positive = Annotated[float, Field(gt=0, le=BIG)]
NonNegative = Annotated[float, Field(ge=0, le=BIG)]
# p / p_B of a machine working near its nominal pressure p_B: 100 p_B is far beyond any discharge surge
PressureRatio = Annotated[float, Field(gt=0, le=100)]
# Upper bounds of size fields (points, samples, intervals), documented in the schema reference
MAX_SWEEP_POINTS = 100_000  # a sweep of the statics: ~2 ms per point
MAX_FORCE_GAP_POINTS = 10_000  # the force-gap characteristic: one IPOPT solve per point


class Strict(BaseModel):
    """A scene section: unknown keys are refused, values are frozen, inf and nan refused."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class Range(Strict):
    """An evenly spaced range of a dimensionless quantity."""

    start: Positive = Field(description="first value, dimensionless")
    stop: Positive = Field(description="last value, dimensionless; larger than start")
    points: Annotated[int, Field(ge=2, le=MAX_SWEEP_POINTS)] = Field(
        description=f"number of evenly spaced values, 2 to {MAX_SWEEP_POINTS}")

    @model_validator(mode="after")
    def _increasing(self):
        if self.stop <= self.start:
            raise ValueError("stop must be larger than start")
        return self

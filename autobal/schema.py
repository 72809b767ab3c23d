"""Building blocks of scenario schemas: strict models (unknown keys refused) and common types.

Each analysis keeps its own schema classes in its own module, built from these blocks and the
quantity types of :mod:`autobal.units`; :mod:`autobal.scenario` assembles them.
"""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, model_validator

Positive = Annotated[float, Field(gt=0)]
NonNegative = Annotated[float, Field(ge=0)]


class Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Range(Strict):
    """An evenly spaced range of a dimensionless quantity."""

    start: Positive
    stop: Positive
    points: Annotated[int, Field(ge=2, le=100000)]

    @model_validator(mode="after")
    def _increasing(self):
        if self.stop <= self.start:
            raise ValueError("stop must be larger than start")
        return self

"""Building blocks of scenario schemas: strict models (unknown keys refused) and common types.

Each analysis keeps its own schema classes in its own module, built from these blocks and the
quantity types of :mod:`autobal.units`; :mod:`autobal.scenario` assembles them.
"""

from __future__ import annotations

from typing import Annotated, get_args

from pydantic import BaseModel, ConfigDict, Field, model_validator
from pydantic.fields import FieldInfo

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


def _unit_text(extra, annotation) -> str | None:
    """The unit text of a quantity field, also inside ``X | None`` and lists."""
    if isinstance(extra, dict) and "unit_text" in extra:
        return extra["unit_text"]
    for meta in getattr(annotation, "__metadata__", ()):
        if isinstance(meta, FieldInfo) and isinstance(meta.json_schema_extra, dict):
            return meta.json_schema_extra.get("unit_text")
    for arg in get_args(annotation):
        text = _unit_text(None, arg)
        if text:
            return text
    return None


def _refuse(self, *args, **kwargs):
    raise TypeError("a validated scene cannot be changed: load it again with set={...} (autobal.load)")


class FrozenList(list):
    """A list of a validated scene: equal to a list, but refuses every change."""

    append = extend = insert = remove = pop = clear = sort = reverse = _refuse
    __setitem__ = __delitem__ = __iadd__ = __imul__ = _refuse

    def __reduce__(self):  # copy and pickle build it whole, not item by item
        return FrozenList, (list(self),)


class FrozenDict(dict):
    """A mapping of a validated scene: equal to a dict, but refuses every change."""

    clear = pop = popitem = setdefault = update = _refuse
    __setitem__ = __delitem__ = __ior__ = _refuse

    def __reduce__(self):
        return FrozenDict, (dict(self),)


def frozen(value):
    """``value`` with its lists and dicts (and theirs) made :class:`FrozenList` / :class:`FrozenDict`."""
    if isinstance(value, list):
        return value if isinstance(value, FrozenList) else FrozenList(frozen(v) for v in value)
    if isinstance(value, dict):
        return value if isinstance(value, FrozenDict) else FrozenDict({k: frozen(v) for k, v in value.items()})
    return value


class Strict(BaseModel):
    """A scene section: unknown keys are refused, values are frozen (lists and dicts too), inf and nan refused."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    @model_validator(mode="after")
    def _freeze_containers(self):
        for name in type(self).model_fields:
            value = getattr(self, name)
            if isinstance(value, list | dict):
                object.__setattr__(self, name, frozen(value))  # the model itself is frozen: set once, here
        return self

    @classmethod
    def __pydantic_init_subclass__(cls, **kwargs):
        """Append each quantity field's unit and physical range (:func:`autobal.units.quantity`) to its
        description, so that the schema reference shows both meaning and unit."""
        super().__pydantic_init_subclass__(**kwargs)
        changed = False
        for f in cls.model_fields.values():
            text = _unit_text(f.json_schema_extra, f.annotation)
            if text and text not in (f.description or ""):
                f.description = f"{f.description}; {text}" if f.description else text
                changed = True
        if changed:
            cls.model_rebuild(force=True)


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

"""Building blocks of scenario schemas: strict models (unknown keys refused) and common types.

Each analysis keeps its own schema classes in its own module, built from these blocks and the
quantity types of :mod:`autobal.units`; :mod:`autobal.scenario` assembles them.
"""

from __future__ import annotations

from typing import Annotated, get_args

from pydantic import BaseModel, ConfigDict, Field, ValidationInfo, create_model, field_validator, model_validator
from pydantic.fields import FieldInfo

from autobal.analysis.run.quantities import KINDS, spelled, unit_of_kind, units_of_kind
from autobal.models.params import BIG

# Dimensionless numbers: finite (every model refuses inf and nan) and at most 1e6 in magnitude, far beyond
# any ratio, coefficient or weight of the sources; tighter bounds where physics gives them (PressureRatio).
Positive = Annotated[float, Field(gt=0, le=BIG)]
NonNegative = Annotated[float, Field(ge=0, le=BIG)]
# p / p_B of a machine working near its nominal pressure p_B: 100 p_B is far beyond any discharge surge
PressureRatio = Annotated[float, Field(gt=0, le=100)]
# Upper bounds of size fields (points, samples, intervals), documented in the schema reference
MAX_SWEEP_POINTS = 100_000  # a sweep of the statics: ~2 ms per point
MAX_FORCE_GAP_POINTS = 10_000  # the force-gap characteristic: one IPOPT solve per point


def _quantity_extra(extra, annotation, key: str) -> str | None:
    """``key`` ("unit_text", "kind") of a quantity field (:func:`autobal.units.quantity`), also inside
    ``X | None`` and lists."""
    if isinstance(extra, dict) and key in extra:
        return extra[key]
    for meta in getattr(annotation, "__metadata__", ()):
        if isinstance(meta, FieldInfo) and isinstance(meta.json_schema_extra, dict):
            return meta.json_schema_extra.get(key)
    for arg in get_args(annotation):
        text = _quantity_extra(None, arg, key)
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


def quantities(model: BaseModel, kinds, path: str = "") -> list[tuple[str, object, str]]:
    """(dotted path, value in SI, kind) of every quantity field of ``model`` (a validated scene or a part
    of it) whose kind is one of ``kinds``; a list field gives its list."""
    out = []
    for name, field in type(model).model_fields.items():
        value, where = getattr(model, name), f"{path}{name}"
        kind = _quantity_extra(field.json_schema_extra, field.annotation, "kind")
        if isinstance(value, BaseModel):
            out += quantities(value, kinds, where + ".")
            continue
        if isinstance(value, dict | list | tuple):
            for k, v in value.items() if isinstance(value, dict) else enumerate(value):
                if isinstance(v, BaseModel):
                    out += quantities(v, kinds, f"{where}.{k}.")
        if value is not None and kind in kinds:
            out.append((where, value, kind))
    return out


def _has_bool(value) -> bool:
    """A boolean in ``value``, or in its lists, tuples and mapping values."""
    if isinstance(value, bool):
        return True
    items = value.values() if isinstance(value, dict) else value if isinstance(value, list | tuple) else ()
    return any(_has_bool(v) for v in items)


def _numbers_only(annotation) -> bool:
    """int or float appear in the type ``annotation``, and neither bool nor a model (which checks its own
    fields) does."""
    seen = set()

    def walk(a):
        model = isinstance(a, type) and issubclass(a, BaseModel)
        seen.add("bool" if a is bool or model else "number" if a in (int, float) else "")
        for arg in get_args(a):
            walk(arg)

    walk(annotation)
    return "number" in seen and "bool" not in seen


def section_at(node, path: str):
    """The section (or value) at the dotted ``path`` below ``node`` (``device.dynamics``), None if a step along it is
    left out."""
    for part in path.split("."):
        node = getattr(node, part, None)
        if node is None:
            return None
    return node


class Strict(BaseModel):
    """A scene section: unknown keys are refused, values are frozen (lists and dicts too), inf and nan refused,
    and so are booleans where a number is expected (pydantic's lax mode reads YAML's yes/on/true as 1)."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    @field_validator("*", mode="before")
    @classmethod
    def _no_boolean_numbers(cls, value, info: ValidationInfo):
        if _has_bool(value) and _numbers_only(cls.model_fields[info.field_name].annotation):
            raise ValueError("a boolean where a number is expected (YAML reads yes/no, on/off, true/false as "
                             "booleans)")
        return value

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
            text = _quantity_extra(f.json_schema_extra, f.annotation, "unit_text")
            if text and text not in (f.description or ""):
                f.description = f"{f.description}; {text}" if f.description else text
                changed = True
        if changed:
            cls.model_rebuild(force=True)


class _DisplayUnits(Strict):
    @field_validator("*")
    @classmethod
    def _unit_of_kind(cls, value, info: ValidationInfo):
        return None if value is None else unit_of_kind(info.field_name, value)


#: the ``display`` section of a scene: kind -> display unit (analysis/run/quantities.py KINDS, DISPLAY_UNITS)
Display = create_model(
    "Display", __base__=_DisplayUnits, __module__=__name__,
    __doc__="The units the terminal summaries, the report tables, the CSV headers and the statics figures show, "
            "by kind of quantity (results.json stays SI); a kind left out keeps each quantity's declared unit "
            "(docs/results.md). `autobal run SCENE --units pressure=bar,flow=m3/h` sets them from the command line.",
    **{kind: (str | None, Field(None, description=f"{what} (SI {spelled(si)}): one of "
                                                  f"{', '.join(units_of_kind(kind))}"))
       for kind, (si, what) in KINDS.items()})


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

"""The scene schema of a part, derived from the SI parameter dataclass of :mod:`autobal.models` that the
physics takes: each physical parameter is declared once, as a field of that dataclass.

A field declared with :func:`autobal.models.params.si` (a number) or :func:`autobal.models.params.section`
(a nested part, or a choice) carries what the scene needs: its SI unit and quantity kind (the units a scene
may write it in), its meaning with the source's symbol, its bounds and its default.  :func:`schema` turns the
dataclass into a pydantic model and :func:`to_params` a validated section back into the dataclass.

- A number's default is the scene's: NaN or inf (the model's "not given" or "unlimited") or None makes the key
  optional, None in the scene being that default.  ``scene_default`` in its metadata overrides it where the
  scene differs from the model (``...``: required in the scene; None: optional, the part's adapter fills it in).
- A field's scene key is its name, or ``key`` in its metadata: another name (``rotor_mass`` for ``m_p``),
  a key of a sub-section (``regulator.stem_mass``: a :class:`Group`), or "" (not in the scene: the part's
  adapter computes it).
- A nested dataclass (a ``section`` field) is a sub-section with its own derived schema.

What a scene has beyond the parameters (an alternative input such as a log decrement for a damping constant,
a datasheet form, a default taken from another section, a check across sections) is written by hand in the
part module: a base class of the derived model (its fields and validators), and the part's ``adapt``.
"""

from __future__ import annotations

import dataclasses
import math
import sys
import typing
from dataclasses import dataclass
from functools import cache
from typing import Annotated, Literal

from pydantic import Field, create_model, model_validator

from autobal.schema import Strict, section_at
from autobal.units import quantity

_PARAMS: dict[type, type] = {}  # derived schema -> its dataclass
#: what a scene must satisfy beyond the checks of a dataclass itself: dataclass -> function(params) raising
#: ValueError (filled by the part modules)
SCENE_CHECKS: dict[type, typing.Callable] = {}


class Checked(Strict):
    """A section whose values are checked by building its dataclass (the dataclass' own ``__post_init__``)
    and by :data:`SCENE_CHECKS`; the base of a section whose dataclass a scene gives whole."""

    @model_validator(mode="after")
    def _dataclass_checks(self):
        params = to_params(self)
        if type(params) in SCENE_CHECKS:
            SCENE_CHECKS[type(params)](params)
        return self


@dataclass(frozen=True)
class Group:
    """A sub-section ``key`` of a scene part that gathers fields of a flat parameter dataclass (the fields
    whose scene key is ``key.name``): its model's name, its meaning, a base class with its scene-only fields
    and validators, and whether the scene may leave it out (the fields then keep the dataclass' defaults)."""

    key: str
    name: str
    doc: str
    base: type = Strict
    optional: bool = False


def key(f: dataclasses.Field) -> str | None:
    """The scene key of a dataclass field (dotted inside a :class:`Group`), None when it is not in a scene."""
    if "unit" not in f.metadata and "doc" not in f.metadata:
        return None  # a plain field (not a declared parameter)
    return f.metadata.get("key", f.name) or None


def _hint(cls: type, f: dataclasses.Field):
    """The type of a field (string annotations resolved in the dataclass' module), None left out."""
    hint = f.type
    if isinstance(hint, str):
        hint = eval(hint, vars(sys.modules[cls.__module__]))  # noqa: S307 (an annotation of our own models)
    args = [a for a in typing.get_args(hint) if a is not type(None)]
    return args[0] if typing.get_args(hint) and len(args) == 1 else hint


def _unset(value) -> bool:
    return value is None or (isinstance(value, float) and not math.isfinite(value))


def _field(cls: type, f: dataclasses.Field) -> tuple:
    """(type, Field) of the scene key of dataclass field ``f``."""
    meta, hint = f.metadata, _hint(cls, f)
    default = meta.get("scene_default", ... if f.default is dataclasses.MISSING else f.default)
    if meta.get("choices"):
        typ = Literal[meta["choices"]]
    elif "unit" in meta:  # a number: a quantity of its kind, or a dimensionless number within its bounds
        bounds = meta["bounds"]
        typ = (quantity(meta["kind"], "nonnegative" if bounds.get("ge") == 0 else "positive") if meta["kind"]
               else Annotated[hint, Field(**bounds)])
        if default is not ... and _unset(default):
            typ, default = typ | None, None
    else:  # a part: its own derived schema
        typ = schema(hint) | None if default is None else schema(hint)
    return typ, Field(default, description=meta.get("doc"))


@cache
def schema(cls: type, name: str | None = None, base: type = Checked, groups: tuple[Group, ...] = (),
           doc: str | None = None) -> type[Strict]:
    """The pydantic schema of a scene section derived from the parameter dataclass ``cls``.

    Parameters
    ----------
    cls : type
        A frozen dataclass of :mod:`autobal.models` whose fields are declared with ``si``/``section``.
    name : str, optional
        The model's name (default the dataclass').
    base : type
        The model's base: :class:`Checked` (the default) builds the dataclass when a section is validated;
        a part whose adapter fills in fields the scene leaves out gives a :class:`Strict` subclass with its
        scene-only fields and validators.
    groups : tuple of Group
        The sub-sections gathering the fields whose scene key is dotted.
    doc : str, optional
        The model's docstring (default the dataclass').

    Returns
    -------
    type
        A pydantic model; unknown keys are refused.
    """
    fields, inner = {}, {g.key: {} for g in groups}
    for f in dataclasses.fields(cls):
        path = key(f)
        if path is None:
            continue
        head, _, rest = path.partition(".")
        if rest:
            inner[head][rest] = _field(cls, f)
            fields.setdefault(head, None)  # the group's place among the fields
        else:
            fields[head] = _field(cls, f)
    for g in groups:
        model = create_model(g.name, __base__=g.base, __module__=g.base.__module__,
                             __doc__=vars(g.base).get("__doc__") or g.doc, **inner[g.key])
        fields[g.key] = (model | None, Field(None, description=g.doc)) if g.optional else (
            model, Field(description=g.doc))
    model = create_model(name or cls.__name__, __base__=base, __module__=base.__module__,
                         __doc__=doc or cls.__doc__, **fields)
    _PARAMS[model] = cls
    return model


def values(section: Strict, cls: type) -> dict:
    """Field name -> value of every field of the dataclass ``cls`` that the validated ``section`` gives (a key
    left out or None, or in a sub-section left out, is not given); nested sections as their dataclasses."""
    kw = {}
    for f in dataclasses.fields(cls):
        path = key(f)
        if path is None:
            continue
        value = section_at(section, path)
        if value is not None:
            kw[f.name] = to_params(value) if type(value) in _PARAMS else value
    return kw


def to_params(section: Strict, **filled):
    """A validated section of a derived schema as its parameter dataclass (SI): what it leaves out takes the
    dataclass' default; ``filled`` are the values the part's adapter computes (they win)."""
    cls = next(_PARAMS[c] for c in type(section).__mro__ if c in _PARAMS)
    return cls(**{**values(section, cls), **filled})

"""Plain parameter objects in SI: the typed boundary of the models.

Every model of :mod:`autobal.models` takes frozen dataclasses of floats in SI units.  A field's unit
is stated in the class docstring and stored in the field's metadata (``si("m")``), so that
:meth:`SIParams.from_quantities` can accept pint quantities as well as plain SI floats.
"""

from __future__ import annotations

import dataclasses

_NO_DEFAULT = dataclasses.MISSING
BIG = 1e6  # bound of a dimensionless number where physics gives none (autobal.schema's too)


def si(unit: str, default=_NO_DEFAULT, *, kind: str | None = None, doc: str = "", key: str | None = None,
       scene_default=_NO_DEFAULT, **bounds):
    """A dataclass field holding a float in the SI unit ``unit`` (e.g. "m", "Pa", "kg/m**3"; "" for a
    dimensionless number), with what a scene schema derived from the class needs (autobal/parts/derived.py).

    Parameters
    ----------
    unit : str
        The SI unit.
    default : float, optional
        The default; NaN (or inf where it means "unlimited") makes the field optional in a scene.
    kind : str, optional
        The quantity kind of a dimensional field ("length", "pressure", ...: the keys of the front door's
        unit table), whose SI unit is ``unit``.
    doc : str
        Its meaning, with the source's symbol, for the schema reference.
    key : str, optional
        Its key in a scene where that is not the field's name: another name, ``"group.name"`` in a sub-section
        of the scene, or "" (not in a scene: the part's adapter computes it).
    scene_default : optional
        Its default in a scene where that is not ``default``: ``...`` (required in the scene, e.g. inside an
        optional sub-section) or None (optional: the part's adapter fills it in, e.g. from another section).
    **bounds
        ``gt``, ``ge``, ``lt``, ``le``: its bounds; ``ge=0`` on a dimensional field admits zero.
    """
    metadata = {"unit": unit, "kind": kind, "doc": doc, "bounds": bounds}
    if key is not None:
        metadata["key"] = key
    if scene_default is not _NO_DEFAULT:
        metadata["scene_default"] = scene_default
    if default is _NO_DEFAULT:
        return dataclasses.field(metadata=metadata)
    return dataclasses.field(default=default, metadata=metadata)


def numbers(*values) -> bool:
    """All ``values`` are plain numbers (not CasADi expressions: a design substitutes symbols into the
    parameter objects, and the checks across fields of ``__post_init__`` apply to numbers only)."""
    return all(isinstance(v, int | float) for v in values)


def section(doc: str, default=_NO_DEFAULT, choices: tuple | None = None):
    """A dataclass field holding a part (a nested parameter object) or a choice among ``choices``, with its
    meaning ``doc`` for the schema reference; default None: the part is optional."""
    metadata = {"doc": doc, "choices": choices}
    if default is _NO_DEFAULT:
        return dataclasses.field(metadata=metadata)
    return dataclasses.field(default=default, metadata=metadata)


class SIParams:
    """Mixin of the parameter dataclasses: construction from pint quantities."""

    @classmethod
    def from_quantities(cls, **values):
        """Build the parameters from SI floats or pint quantities.

        Parameters
        ----------
        **values
            Field name -> value.  A value with a ``to`` method (a pint ``Quantity``, e.g.
            ``ureg("0.35 mm")``) is converted with ``.to(unit).magnitude`` to the field's SI unit;
            a float is taken as SI already; other values (nested parameter objects, strings) are
            passed through.

        Returns
        -------
        SIParams
            The frozen parameter object.
        """
        units = {f.name: f.metadata.get("unit") for f in dataclasses.fields(cls)}
        out = {}
        for name, v in values.items():
            unit = units.get(name)
            if unit is not None and hasattr(v, "to") and hasattr(v, "magnitude"):
                v = float(v.to(unit or "dimensionless").magnitude)
            out[name] = v
        return cls(**out)

    def units(self) -> dict:
        """Field name -> SI unit of every float field ("" for dimensionless numbers)."""
        return {f.name: f.metadata["unit"] for f in dataclasses.fields(self) if "unit" in f.metadata}


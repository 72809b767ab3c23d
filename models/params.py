"""Plain parameter objects in SI: the typed boundary of the models.

Every model of :mod:`autobal.models` takes frozen dataclasses of floats in SI units.  A field's unit
is stated in the class docstring and stored in the field's metadata (``si("m")``), so that
:meth:`SIParams.from_quantities` can accept pint quantities as well as plain SI floats.
"""

from __future__ import annotations

import dataclasses

_NO_DEFAULT = dataclasses.MISSING


def si(unit: str, default=_NO_DEFAULT):
    """A dataclass field holding a float in the SI unit ``unit`` (e.g. "m", "Pa", "kg/m**3"; "" for a
    dimensionless number)."""
    if default is _NO_DEFAULT:
        return dataclasses.field(metadata={"unit": unit})
    return dataclasses.field(default=default, metadata={"unit": unit})


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


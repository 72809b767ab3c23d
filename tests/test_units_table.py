"""The unit table that reads plain SI-prefixed units without pint gives pint's factors (autobal/units.py);
the angular kinds are read by their own table (tests/test_units_rotational.py)."""

import math
import subprocess
import sys

import pytest

from autobal import units
from autobal.units import DIMENSIONS

NAMES = [*units._TABLE, *(p + n for p in units._PREFIXES for n in units._PREFIXED)]
COMPOUND = ["m^3/s", "m**3 / s", "kg/m^3", "N*s/m", "Pa*s", "mPa*s", "kg*m**2", "N*m*s", "1/s", "1 / min",
            "L/min", "mL", "µm", "μm", "um", "kN*m", "g/cm^3", "kg/m*s", "m/s/s", "bar"]


def pint_factor(unit: str):
    """pint's unit of ``unit`` and the registry."""
    ureg = units.registry()
    return ureg.parse_units(unit), ureg


@pytest.mark.parametrize("name", NAMES + COMPOUND)
def test_the_table_gives_pints_factor_and_dimension(name):
    mine = units._table_unit(name)
    u, ureg = pint_factor(name)
    if mine is None:  # a name pint reads otherwise ("hbar", the reduced Planck constant) is left to pint
        assert name == "hbar"
        return
    base = ureg.Quantity(1.0, u).to_base_units()
    dims = base.dimensionality
    assert set(dims) <= {"[mass]", "[length]", "[time]"}
    assert tuple(dims.get(d, 0) for d in ("[mass]", "[length]", "[time]")) == mine[1]
    assert mine[0] == pytest.approx(base.magnitude, rel=1e-14)
    kinds = [k for k, (dim, *_rest) in DIMENSIONS.items() if u.dimensionality == ureg.get_dimensionality(dim)]
    for kind in set(kinds) - set(units.ANGULAR):
        si = DIMENSIONS[kind][1]
        assert units._fast(name, kind) == pytest.approx(ureg.Quantity(1.0, u).to(si).magnitude, rel=1e-14)
    for kind in set(DIMENSIONS) - set(kinds):  # another dimension: left to pint, which explains the error
        assert units._fast(name, kind) is None


def test_every_si_unit_of_the_table_has_factor_one():
    for kind, (_, si, _, _) in DIMENSIONS.items():
        if kind in units.ANGULAR:
            assert units._angular(si, kind) == 1.0, kind
        else:
            assert units._table_unit(si)[0] == 1.0, kind


def test_rpm_and_minutes():
    assert units.to_si("6300 rpm", "angular speed") == pytest.approx(6300 * 2 * math.pi / 60, rel=1e-15)
    assert units.to_si("3 L/min", "volume flow") == pytest.approx(5e-5, rel=1e-15)
    with pytest.raises(ValueError, match="not a length"):
        units.to_si("3 MPa", "length")


def test_a_statics_scene_loads_without_pint():
    code = ("import sys; from autobal import scenario; scenario.load('pump_pe600_statics'); "
            "print('pint' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True)
    assert out.stdout.split()[-1] == "False"

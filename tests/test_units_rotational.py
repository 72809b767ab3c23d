"""Rotational quantities as engineers write them (ISO 80000-3, autobal/units.py): a speed in Hz, rps, rpm,
r/min or 1/min is a rotational frequency n and omega = 2 pi n; accelerations and jerks likewise; rad/s and
deg/s as written; a bare 1/s on an angular field is refused as ambiguous; a rate (chi/m1, the liquid
balancer's n) stays in 1/s; booleans are refused where a number is expected."""

import math

import numpy as np
import pytest
import yaml
from pydantic import ValidationError

from autobal import api, cli, scenario, units
from autobal.errors import ScenarioError
from autobal.schema import quantities

SPEED, ACCEL, JERK = "angular speed", "angular acceleration", "angular jerk"


@pytest.mark.parametrize("value, kind, si", [
    ("105 Hz", SPEED, 659.734),  # 6300 rpm
    ("6300 rpm", SPEED, 659.734),
    ("4000 1/min", SPEED, 418.879),  # min^-1, as European datasheets write rpm
    ("4000 min^-1", SPEED, 418.879),
    ("4000 r/min", SPEED, 418.879),
    ("4000 rpm", SPEED, 418.879),
    ("66.6667 rps", SPEED, 418.879),
    ("66.6667 r/s", SPEED, 418.879),
    ("1.05 kHz", SPEED, 6597.34),  # a prefixed hertz is a rotational frequency as well
    ("5730 deg/s", SPEED, 100.007),
    ("100 rad/s", SPEED, 100.0),
    ("10 Hz/s", ACCEL, 62.8319),
    ("100 rpm/s", ACCEL, 10.4720),
    ("6000 rpm/min", ACCEL, 10.4720),
    ("600 1/min/s", ACCEL, 62.8319),
    ("40 rad/s^2", ACCEL, 40.0),
    ("2292 deg/s**2", ACCEL, 40.0029),
    ("2 Hz/s^2", JERK, 12.5664),
    ("2000 rad/s^3", JERK, 2000.0),
])
def test_rotational_units_read_as_omega_equals_two_pi_n(value, kind, si):
    assert units.to_si(value, kind) == pytest.approx(si, rel=5e-6)


def test_rad_per_second_is_taken_as_written():
    assert units.to_si("100 rad/s", SPEED) == 100.0
    assert units.to_si("40 rad/s^2", ACCEL) == 40.0


# the same unit with the revolution made explicit for pint (pint reads Hz and 1/min as 1/s, 1/(60 s))
PINT_SPELLING = [
    ("rpm", SPEED, "rpm"), ("r/min", SPEED, "turn/min"), ("1/min", SPEED, "turn/min"), ("min^-1", SPEED, "turn/min"),
    ("Hz", SPEED, "turn*Hz"), ("kHz", SPEED, "turn*kHz"), ("mHz", SPEED, "turn*mHz"), ("rps", SPEED, "rps"),
    ("r/s", SPEED, "turn/s"), ("rev/s", SPEED, "turn/s"), ("deg/s", SPEED, "deg/s"), ("°/s", SPEED, "deg/s"),
    ("rad/s", SPEED, "rad/s"), ("mrad/ms", SPEED, "mrad/ms"), ("rad/min", SPEED, "rad/min"),
    ("revolutions_per_minute", SPEED, "rpm"), ("radian/second", SPEED, "rad/s"), ("hertz", SPEED, "turn*Hz"),
    ("Hz/s", ACCEL, "turn*Hz/s"), ("rpm/s", ACCEL, "rpm/s"), ("rpm/min", ACCEL, "rpm/min"),
    ("deg/s^2", ACCEL, "deg/s^2"), ("rad/s**2", ACCEL, "rad/s**2"), ("rad/s/s", ACCEL, "rad/s/s"),
    ("Hz/s^2", JERK, "turn*Hz/s^2"), ("rpm/s^2", JERK, "rpm/s^2"), ("rad/s^3", JERK, "rad/s^3"),
]


@pytest.mark.parametrize("unit, kind, spelled", PINT_SPELLING)
def test_the_rotational_table_gives_pints_factor_with_the_revolution_explicit(unit, kind, spelled):
    ureg = units.registry()
    expected = ureg.Quantity(1.0, ureg.parse_units(spelled)).to(units.DIMENSIONS[kind][1]).magnitude
    assert units.unit_factor(unit, kind) == pytest.approx(expected, rel=1e-14)


@pytest.mark.parametrize("n", [float(n) for n in np.geomspace(1e-3, 1e5, 17)])
def test_hz_rps_rpm_and_per_minute_agree_over_the_range(n):
    omega = 2 * math.pi * n
    for text in (f"{n!r} Hz", f"{n!r} rps", f"{60 * n!r} rpm", f"{60 * n!r} 1/min", f"{60 * n!r} r/min"):
        assert units.to_si(text, SPEED) == pytest.approx(omega, rel=1e-13), text
    assert units.to_si(f"{n!r} Hz/s", ACCEL) == pytest.approx(omega, rel=1e-13)
    assert units.to_si(f"{omega!r} rad/s", SPEED) == omega


@pytest.mark.parametrize("value, kind, names", [
    ("100 1/s", SPEED, ("rad/s", "Hz")),
    ("100 s^-1", SPEED, ("rad/s", "Hz")),
    ("100 1 / s", SPEED, ("rad/s", "Hz")),
    ("100 1/ms", SPEED, ("rad/s", "Hz")),
    ("40 1/s^2", ACCEL, ("rad/s^2", "Hz/s")),
    ("40 s**-2", ACCEL, ("rad/s^2", "Hz/s")),
    ("9 1/s^3", JERK, ("rad/s^3", "Hz/s^2")),
])
def test_a_bare_inverse_second_is_refused_as_ambiguous(value, kind, names):
    with pytest.raises(ValueError, match="ambiguous") as err:
        units.to_si(value, kind)
    assert all(name in str(err.value) for name in names), err.value
    assert "\n" not in str(err.value)


@pytest.mark.parametrize("value, kind", [
    ("100 rad/s", ACCEL), ("40 rad/s^2", SPEED), ("10 Hz/s", SPEED), ("100 Hz", JERK), ("5 rad", SPEED),
    ("5 m/s", SPEED), ("5 kg", ACCEL), ("5 rad*m/s", SPEED), ("5 furlong/s", SPEED), ("5 rad s^-1", SPEED),
])
def test_other_units_on_an_angular_field_are_refused_naming_what_to_write(value, kind):
    with pytest.raises(ValueError, match=rf"not a unit of an {kind}: write rad/s"):
        units.to_si(value, kind)


def test_a_rate_keeps_inverse_seconds_and_refuses_rotational_units():
    assert units.to_si("7.85 1/s", "rate") == 7.85
    assert units.to_si("60 1/min", "rate") == pytest.approx(1.0, rel=1e-15)
    for value in ("7.85 Hz", "7.85 rpm", "7.85 rad/s", "7.85 kHz", "7.85 hertz"):
        with pytest.raises(ValueError, match="is a rotational unit, not one of a rate: write 1/s"):
            units.to_si(value, "rate")


def test_si_unit_of_a_value_as_written():
    assert units.si_unit_of("105 Hz") == "rad/s"
    assert units.si_unit_of("4000 1/min") == "rad/s"
    assert units.si_unit_of("10 Hz/s") == "rad/s**2"
    assert units.si_unit_of("7.85 1/s") == "1/s"
    assert units.si_unit_of("0.35 mm") == "m"
    assert units.si_unit_of("1" * 200 + " Hz") == ""


def test_angular_text_in_rad_per_second_and_rpm():
    assert units.angular_text(2 * math.pi * 105, SPEED) == "659.73 rad/s (6300 rpm)"
    assert units.angular_text(2 * math.pi, ACCEL) == "6.2832 rad/s^2 (60 rpm/s)"
    assert units.angular_text([(0.0, 2 * math.pi)], SPEED) == "[[0, 6.2832]] rad/s ([[0, 60]] rpm)"


# ---- through the scene ----------------------------------------------------------------------------------

@pytest.mark.parametrize("scene, path, value, si", [
    ("pump_pe600_statics", "device.operating.impeller.speed", "105 Hz", 659.734),
    ("spinup_jeffcott_deadline_5s", "analyses.spinup.final_speed", "2000 1/min", 209.440),
    ("spinup_jeffcott_deadline_5s", "analyses.spinup.max_acceleration", "10 Hz/s", 62.8319),
    ("spinup_jeffcott_deadline_5s", "analyses.spinup.start_speed", "0 rpm", 0.0),
    ("pump_pe600_dynamics", "analyses.frequency.omega.stop", "1 kHz", 6283.19),
    ("washer_liquid_balancer", "liquid_balancer.rotor.damping_coefficient", "7.85 1/s", 7.85),
    ("pashkov_runup", "analyses.rotor_dynamics.passage.friction", ["0 1/s", "5 1/s", "60 1/min"], [0.0, 5.0, 1.0]),
    ("pashkov_runup", "analyses.rotor_dynamics.steps.steps", [["0 rpm", "25 Hz"]], [(0.0, 157.080)]),
])
def test_a_scene_reads_rotational_units(scene, path, value, si):
    scn = scenario.load(scene, overrides={path: value})
    got = scn
    for key in path.split("."):
        got = getattr(got, key)
    assert np.asarray(got, float) == pytest.approx(np.asarray(si, float), rel=5e-6)


@pytest.mark.parametrize("scene, path, value, text", [
    ("pump_pe600_statics", "device.operating.impeller.speed", "659.7 1/s", "'1/s' is ambiguous for an angular speed"),
    ("washer_liquid_balancer", "liquid_balancer.rotor.damping_coefficient", "7.85 Hz", "'Hz' is a rotational unit"),
    ("pashkov_runup", "analyses.rotor_dynamics.passage.friction", ["5 rpm"], "'rpm' is a rotational unit"),
])
def test_a_scene_refuses_ambiguous_or_rotational_units_naming_the_field(scene, path, value, text):
    with pytest.raises(ScenarioError, match=path.replace(".", r"\.")) as err:
        scenario.load(scene, overrides={path: value})
    assert text in str(err.value)


def test_a_pint_quantity_given_through_the_api_follows_the_same_rule():
    ureg = units.registry()
    for q, si in [(ureg.Quantity(105, "Hz"), 659.734), (ureg.Quantity(6300, "rpm"), 659.734),
                  (ureg.Quantity(659.734, "rad/s"), 659.734), (ureg.Quantity(4000, "1/min"), 418.879)]:
        scn = api.load("pump_pe600_statics", set={"device.operating.impeller.speed": q})
        assert scn.device.operating.impeller.speed == pytest.approx(si, rel=5e-6), q
    with pytest.raises(ScenarioError, match="ambiguous"):
        api.load("pump_pe600_statics", set={"device.operating.impeller.speed": ureg.Quantity(659.7, "1/s")})


def _raw(data, path: str):
    for key in path.split("."):
        if isinstance(data, list):
            data = data[int(key)]
        elif isinstance(data, dict) and key in data:
            data = data[key]
        else:
            return None
    return data


def _units_written(value) -> list[str]:
    if isinstance(value, list | tuple):
        return [u for v in value for u in _units_written(v)]
    return [value.split(maxsplit=1)[1] if isinstance(value, str) and " " in value.strip() else repr(value)]


@pytest.mark.parametrize("path", scenario.shipped(), ids=lambda p: p.stem)
def test_no_shipped_scene_changes_meaning(path):
    """Every angular quantity a shipped scene writes is in rpm or rad/s^k, units whose meaning the
    rotational rules do not change (ISO 80000-3 reads only Hz, rps and 1/min differently from pint)."""
    raw = scenario.read(path)
    scn = scenario.load(path)
    written = []
    for where, value, kind in quantities(scn, units.ANGULAR):
        given = _raw(raw, where)
        if given is not None:
            written += _units_written(given)
            assert np.asarray(value, float) == pytest.approx(
                np.asarray(_si(given, kind), float), rel=1e-15), where
    assert set(written) <= {"rpm", "rad/s", "rad/s^2", "rad/s^3"}, written


def _si(given, kind):
    ureg = units.registry()
    if isinstance(given, list | tuple):
        return [_si(g, kind) for g in given]
    number, unit = given.split(maxsplit=1)
    return ureg.Quantity(float(number), ureg.parse_units(unit)).to(units.DIMENSIONS[kind][1]).magnitude


# ---- booleans and the check output ------------------------------------------------------------------

@pytest.mark.cli
@pytest.mark.parametrize("path, value", [
    ("device.barrier.margin_ratio", True),  # a float field
    ("device.operating.impeller.stages", True),  # an int field
    ("device.operating.thrust_ratio", False),
    ("analyses.statics.discharge_ratio.points", True),
    ("device.operating.impeller.speed", True),  # a quantity
])
def test_a_boolean_is_refused_where_a_number_is_expected(tmp_path, capsys, path, value):
    data = scenario.read(scenario.resolve("pump_pe600_statics"))
    node = data
    *parents, last = path.split(".")
    for key in parents:
        node = node[key]
    node[last] = "yes" if value else "off"  # YAML 1.1 reads both as booleans
    p = tmp_path / "scene.yaml"
    p.write_text(yaml.safe_dump(data).replace("'yes'", "yes").replace("'off'", "off"))
    node = yaml.safe_load(p.read_text())
    for key in path.split("."):
        node = node[key]
    assert node is value
    assert cli.main(["check", str(p)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{path}: " in err[0] and ("boolean" in err[0] or "with a unit" in err[0]), err


def _strict_models():
    import importlib

    from autobal.schema import Strict

    for name in ("scenario", "schema_rotor", "schema_dynamics", "schema_design", "schema_estimation",
                 "schema_liquid_balancer", "schema_reliability", "schema_ross"):
        importlib.import_module(f"autobal.{name}")
    todo, seen = [Strict], set()
    while todo:
        for sub in todo.pop().__subclasses__():
            if sub not in seen:
                seen.add(sub)
                todo.append(sub)
    return sorted(seen, key=lambda c: (c.__module__, c.__qualname__))


def test_every_numeric_field_of_every_scene_section_refuses_a_boolean():
    from autobal.schema import _numbers_only

    checked = 0
    for cls in _strict_models():
        for name, field in cls.model_fields.items():
            if not _numbers_only(field.annotation):
                continue
            with pytest.raises(ValidationError) as err:
                cls.model_validate({name: True})
            mine = [e for e in err.value.errors() if e["loc"][:1] == (name,)]
            assert mine and ("a boolean where a number is expected" in mine[0]["msg"]
                             or "with a unit" in mine[0]["msg"]), (cls.__qualname__, name, mine)
            checked += 1
    assert checked > 150  # the sections' int, float, ratio and quantity fields


def test_an_integer_still_passes_for_a_float_field():
    scn = scenario.load("pump_pe600_statics", overrides={"device.barrier.margin_ratio": 1})
    assert scn.device.barrier.margin_ratio == 1.0
    scn = scenario.load("pump_pe600_design", overrides={"analyses.design.operating_ratios": [1, 2]})
    assert scn.analyses.design.operating_ratios == [1.0, 2.0]
    with pytest.raises(ScenarioError, match=r"analyses\.design\.operating_ratios: a boolean"):
        scenario.load("pump_pe600_design", overrides={"analyses.design.operating_ratios": [1, True]})


@pytest.mark.cli
def test_check_prints_each_angular_quantity_in_rad_per_second_and_rpm(capsys):
    assert cli.main(["check", "pump_pe600_statics", "--set", "device.operating.impeller.speed=105 Hz"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("pump_pe600_statics: valid")
    assert out[1].strip() == "device.operating.impeller.speed = 659.73 rad/s (6300 rpm)"
    assert cli.main(["check", "spinup_jeffcott_deadline_5s", "--set", "analyses.spinup.final_speed=2000 1/min"]) == 0
    out = capsys.readouterr().out
    assert "analyses.spinup.final_speed = 209.44 rad/s (2000 rpm)" in out
    assert "analyses.spinup.max_acceleration = 40 rad/s^2 (381.97 rpm/s)" in out

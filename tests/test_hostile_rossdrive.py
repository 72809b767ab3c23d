"""Hostile input to the drive of the ROSS rotor (``ross_rotor.drive``): each bad value exits 2 at load time with one
line on stderr naming the field and the unit; the robust and time-optimal studies of the ROSS rotor, which take the
acceleration limit only, refuse a drive section in one line before ROSS is imported."""

import pytest

from tests.hostile import refused

pytestmark = pytest.mark.cli
DRIVE = "ross_rotor.drive"


@pytest.mark.parametrize("sets, words", [
    ([f"{DRIVE}.max_power=-2 kW"], f"{DRIVE}.max_power: must be positive, got -2000 W"),
    ([f"{DRIVE}.max_torque=150"], f"{DRIVE}.max_torque: 150 has no unit: write a torque"),
    ([f"{DRIVE}.max_braking_torque=-1 N*m"], f"{DRIVE}.max_braking_torque: must not be negative"),
    ([f"{DRIVE}.max_deceleration=-1 rad/s^2"], f"{DRIVE}.max_deceleration: must not be negative"),
    ([f"{DRIVE}.polar_inertia=3 kg"], f"{DRIVE}.polar_inertia: '3 kg' is not a moment of inertia"),
    ([f"{DRIVE}.efficiency=0.9"], "efficiency"),
])
def test_bad_drive_values_exit_2_naming_the_field_and_the_unit(capsys, sets, words):
    assert words in refused(capsys, "spinup_ross_rotor", *sets)


@pytest.mark.extra("ross")  # without ross, run refuses the scene first, naming the extra
@pytest.mark.parametrize("scene", ["ross_spinup_robust", "ross_spinup_time_optimal"])
def test_studies_without_a_drive_model_refuse_a_drive_section(capsys, scene):
    err = refused(capsys, scene, f"{DRIVE}.max_power=2 kW")
    assert f"analyses.{scene}: {DRIVE}: this study of the ROSS rotor takes the acceleration limit only" in err

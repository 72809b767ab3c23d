"""Hostile input to the robust spin-up of the ROSS rotor (ross_spinup_robust): each case exits 2 at load time with
one line on stderr naming the field (no ROSS needed: the scene is refused before the rotor is built)."""

import pytest

from tests.hostile import refused

pytestmark = pytest.mark.cli
KEY = "analyses.ross_spinup_robust"


@pytest.mark.parametrize("sets, words", [
    ([f"{KEY}.damping_factor=[2.0, 0.5]"], "damping_factor"),
    ([f"{KEY}.damping_factor=[0.0, 0.5]"], "damping_factor"),
    ([f"{KEY}.critical_speed_spread=0.9"], "critical_speed_spread"),
    ([f"{KEY}.validate_with_ross=false"], "validate_with_ross"),
    ([f"{KEY}.liquid_mass_factor=[1.0, 2.0]"], "liquid_mass_factor"),
    ([f"{KEY}.design_points=0"], "design_points"),
    ([f"{KEY}.max_acceleration=10 rad/s^2"], "max_acceleration"),
])
def test_bad_robust_settings_exit_2_naming_the_field(capsys, sets, words):
    assert words in refused(capsys, "ross_spinup_robust", *sets)

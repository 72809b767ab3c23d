"""Hostile input to the time-optimal spin-up of the ROSS rotor (ross_spinup_time_optimal): each bad setting exits 2
at load time with one line on stderr naming the field and the unit (no ROSS needed: the scene is refused before the
rotor is built); a limit no arrival can keep is a SolveError naming the limit and the smallest reachable peak in µm."""

from types import SimpleNamespace

import pytest

from autobal.errors import SolveError
from autobal.ocp import time_optimal as to
from tests.hostile import refused
from tests.test_ross_spinup_time_optimal import small

KEY = "analyses.ross_spinup_time_optimal"


@pytest.mark.cli
@pytest.mark.parametrize("sets, words", [
    ([f"{KEY}.deflection_limit=-1 um"], "deflection_limit: must be positive"),
    ([f"{KEY}.deflection_limit=0 um"], "deflection_limit: must be positive"),
    ([f"{KEY}.deflection_limit=7"], "has no unit: write a length"),
    ([f"{KEY}.deflection_limit=7 rad/s"], "is not a length"),
    ([f"{KEY}.front_points=1"], "front_points"),
    ([f"{KEY}.validate_with_ross=true"], "validate_with_ross"),
    ([f"{KEY}.max_acceleration=10 rad/s^2"], "max_acceleration"),
    ([f"{KEY}.max_speed=70 rad/s"], "max_speed"),
])
def test_bad_time_optimal_settings_exit_2_naming_the_field(capsys, sets, words):
    err = refused(capsys, "ross_spinup_time_optimal", *sets)
    assert words in err and KEY in err


def test_a_limit_below_every_reachable_peak_is_an_infeasible_solve_naming_it():
    """When no deadline of the front keeps the limit (here below its smallest peak, 5 µm at the horizon), SolveError
    names the limit and the smallest reachable peak in µm (the modal problem's unit), never a result."""
    ocp = small(deflection_limit=1e-9)
    fr = to.Front([SimpleNamespace(arrival_time_s=0.4, peak=6e-6), SimpleNamespace(arrival_time_s=0.6, peak=5e-6)],
                  SimpleNamespace(peak=8e-6), 0.2)
    with pytest.raises(SolveError) as exc:
        to.earliest_arrival(ocp, ocp.method, ocp.deflection_limit, fr)
    assert exc.value.status == "Infeasible_Problem_Detected"
    assert exc.value.message.endswith("deflection limit 0.001 um; the smallest peak reachable by the horizon 0.6 s "
                                      "is 5 um")
    assert exc.value.last_iterate == {"smallest_peak_m": 5e-6}

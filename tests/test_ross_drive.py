"""The drive's deceleration limit on the modal (ROSS) rotor's spin-up (issue 26, item 2): ``max_deceleration`` of
the ROSS analyses bounds alpha from below in the shared transcription, the search and the starts, as the Jeffcott
rotor's drive does (0: the speed never falls)."""

import dataclasses

import numpy as np
import pytest

from autobal.analyses.ross_spinup import RossSpinup, _alpha_min
from autobal.models import ross_rotor as rr
from autobal.ocp import modal
from autobal.ocp.solve import optimize
from tests.test_ross_rotor import disk_rotor


@pytest.fixture(scope="module")
def free_and_no_braking():
    red = rr.reduce(disk_rotor(), [rr.Unbalance(0, 1e-4)], omega_final=150.0, cutoff=1.5)
    ocp = modal.ModalSpinupOcp(red, 50.0, 150.0, 1.5, 100.0, (0,), settling_time=0.3, omega_max=150.0, intervals=30)
    return [optimize(p, p.method, options={"max_iter": 300}) for p in (ocp, dataclasses.replace(ocp, alpha_min=0.0))]


def test_no_deceleration_keeps_the_speed_from_falling(free_and_no_braking):
    free, held = free_and_no_braking
    assert free.solution.u.min() < -0.5  # the free optimum backs off before the critical speed
    assert held.solution.u.min() >= -1e-8  # the bound of the shared transcription
    assert held.trajectory.alpha.min() >= -1e-8 * held.ocp.alpha_max
    assert np.all(np.diff(held.trajectory.omega) >= -1e-9 * held.ocp.omega_final)
    # a bound can only cost: the held optimum peaks no lower than the free one (to the re-simulation's accuracy)
    assert held.trajectory.peak >= free.trajectory.peak * (1 - 1e-4)


def test_the_search_keeps_the_deceleration_limit(free_and_no_braking):
    held = free_and_no_braking[1].ocp
    for _, u in modal.starts(held, held.intervals):
        assert u.min() >= -1e-12


def test_scene_max_deceleration_is_the_lowest_acceleration():
    kw = {"start_speed": "0 rad/s", "final_speed": "80 rad/s", "horizon": "3 s", "max_acceleration": "40 rad/s^2",
          "nodes": [2]}
    assert _alpha_min(RossSpinup(**kw)) is None
    assert _alpha_min(RossSpinup(**kw, max_deceleration="10 rad/s^2")) == -10.0
    assert _alpha_min(RossSpinup(**kw, max_deceleration="0 rad/s^2")) == 0.0
    with pytest.raises(ValueError, match="max_deceleration"):
        RossSpinup(**kw, max_deceleration="-1 rad/s^2")
    with pytest.raises(ValueError, match="minimum acceleration must not be positive"):
        dataclasses.replace(modal.ModalSpinupOcp(rr.reduce(disk_rotor(), [rr.Unbalance(0, 1e-4)], 150.0, 1.5), 50.0,
                                                 150.0, 1.5, 100.0, (0,), intervals=30), alpha_min=1.0)

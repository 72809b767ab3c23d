"""Hostile input to the generic OCP pipeline: a rotor model that cannot take what the generic code asks of it
says so in one line."""

import numpy as np
import pytest

from autobal.models import ross_rotor as rr
from autobal.ocp import modal
from autobal.ocp import robust as rb


def disk_ocp() -> modal.ModalSpinupOcp:
    M, K, C = np.diag([10.0, 10.0, 0.05, 0.05]), np.diag([1e5, 1e5, 4e4, 4e4]), np.diag([20.0, 20.0, 0.0, 0.0])
    lat = rr.LateralMatrices(M, K, C, np.zeros((4, 4)), np.zeros((4, 4)), nodes=1)
    red = rr.reduce(lat, [rr.Unbalance(0, 1e-4)], omega_final=150.0, cutoff=1.5)
    return modal.ModalSpinupOcp(red, 50.0, 150.0, 1.5, 100.0, (0,), intervals=10)


def test_modal_rotor_refuses_a_liquid_mass_factor():
    """The modal rotor has no liquid block: a robust design set that scales a liquid mass is refused, naming it."""
    with pytest.raises(ValueError, match="no liquid block: its liquid-mass factor must be 1"):
        rb.scenario_ocps(disk_ocp(), np.array([[1.0, 1.0, 1.2]]))


def test_perturbed_modal_rotor_keeps_the_nominal_scales():
    """Every scenario of a robust NLP shares one epigraph: a perturbed modal problem keeps the nominal's state
    and epigraph scales while its natural frequencies move by the critical-speed factor."""
    o = disk_ocp()
    p = o.perturbed([1.05, 0.5, 1.0])
    assert p.amplitude_scale == o.amplitude_scale and p.peak_scale2 == o.peak_scale2
    np.testing.assert_allclose(p.rotor.omega_n, 1.05 * o.rotor.omega_n, rtol=1e-12)
    np.testing.assert_allclose(p.rotor.critical_speeds(200.0)["wd"][0] / o.rotor.critical_speeds(200.0)["wd"][0],
                               1.05, rtol=2e-3)

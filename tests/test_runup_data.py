"""Measured run-ups read into 1x vectors (autobal/runup_data.py).

The vector files of tests/data/runup/ were written from the steady Jeffcott response
X = e r^2 / (1 - r^2 + 2 i zeta r) exp(i beta) (r = omega / omega_n), rounded to 0.001 µm peak-to-peak and
0.01°; the reading must give that response back within the rounding.  Raw signals are synthesised here with a
known 1x vector and a known quadratic shaft angle, and order tracking must recover the vector within a bound
derived from the noise and the sampling.
"""

import math
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from autobal.runup_data import OneX, read_vectors

DATA = Path(__file__).parent / "data" / "runup"
RPM = 2 * math.pi / 60
SPEEDS = np.arange(600, 4801, 200.0) * RPM  # the files' speeds


def jeffcott(speed, critical=3000 * RPM, zeta=0.05, e=5e-6, beta=math.pi / 6):
    """Steady 0-peak 1x vector of a Jeffcott rotor in the toolkit's convention x = Re(X exp(i phi))."""
    r = speed / critical
    return e * r**2 / (1 - r**2 + 2j * zeta * r) * np.exp(1j * beta)


def test_plain_vectors_are_the_jeffcott_response_in_si():
    one = read_vectors(DATA / "vectors_plain.csv", amplitude="peak-to-peak", phase="lag")
    assert isinstance(one, OneX) and one.y is None and one.path.endswith("vectors_plain.csv")
    assert_allclose(one.speed, SPEEDS, rtol=1e-12)
    assert_allclose(one.time, 0.5 * np.arange(len(SPEEDS)))
    # rounding: 0.0005 µm of the peak-to-peak amplitude (0.00025 µm 0-peak) and 0.005° of the phase
    ref = jeffcott(SPEEDS)
    assert_allclose(np.abs(one.x), np.abs(ref), atol=0.26e-9)
    assert_allclose(np.angle(one.x / ref), 0, atol=math.radians(0.0051))
    # the analyser's 0-360° phase crossed 360° once (330° -> 0° going through -30° lag): unwrapped, noted
    assert any("wrapped by the analyser at 0-360°: 1 step(s)" in n for n in one.notes), one.notes


def test_lag_lead_and_amplitude_conventions_are_the_same_vectors():
    pp_lag = read_vectors(DATA / "vectors_plain.csv", amplitude="peak-to-peak", phase="lag")
    op_lead = read_vectors(DATA / "vectors_plain.csv", amplitude="0-peak", phase="lead")
    # the same numbers read as 0-peak are twice as large, read as a lead are the mirror image
    assert_allclose(op_lead.x, 2 * np.conj(pp_lag.x), rtol=1e-12)

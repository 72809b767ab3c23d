"""Hostile input to the required decay rate of ``analyses.stability`` (the margin of its one verdict): a wrong unit, a
bare number, a negative or an absurd rate, a word. Each ends with exit 2 and one line naming the field and the unit."""

from __future__ import annotations

import pytest

import autobal
from tests.test_hostile_units import refused

FIELD = "analyses.stability.decay_rate"


@pytest.mark.cli
@pytest.mark.parametrize("value, words", [
    ("50 mm", "is not a rate"),
    ("50", "has no unit"),
    ("-5 1/s", "must not be negative"),
    ("1e30 1/s", "1/s"),
    ("fast", "1/s"),
    ("50 rad/s", "1/s"),
])
def test_a_bad_required_decay_rate_is_one_line_naming_the_field_and_the_unit(capsys, value, words):
    line = refused(capsys, ["pump_pe600_dynamics", "--set", f"{FIELD}={value}"])
    assert FIELD in line and words in line, line


def test_a_required_decay_rate_with_its_unit_is_read_in_si():
    scene = autobal.load("pump_pe600_dynamics", set={FIELD: "3000 1/min"})
    assert scene.analyses.stability.decay_rate == pytest.approx(50.0, rel=1e-12)
    assert autobal.load("pump_pe600_dynamics").analyses.stability.decay_rate == 0.0  # default: none required

"""Stable intervals of a parameter scan end at the stability boundary (the root of max Re lambda between two grid
points), not at the last stable grid point."""

from __future__ import annotations

import math

import numpy as np
import pytest

from autobal.analysis.numerics.stability import _intervals


def test_a_boundary_is_the_root_between_grid_points():
    vals = np.geomspace(1.0, 1000.0, 15)
    growth = lambda v: math.log(v / 235.0)  # noqa: E731  stable below 235, unstable above
    r = np.array([growth(v) for v in vals])
    assert _intervals(vals, r, growth) == [[1.0, pytest.approx(235.0, rel=1e-6)]]
    assert vals[r < 0][-1] < 0.97 * 235.0  # the last stable grid point (227.6): what the summary used to print
    # without a function: the straight line between the two grid points (not the grid point)
    lo, hi = _intervals(vals, r)[0]
    assert lo == 1.0 and vals[r < 0][-1] < hi < vals[r >= 0][0]


def test_two_intervals_and_the_range_ends():
    vals = np.linspace(0.0, 10.0, 11)
    growth = lambda v: (v - 2.5) * (v - 6.5)  # noqa: E731  stable between 2.5 and 6.5
    r = np.array([growth(v) for v in vals])
    assert _intervals(vals, r, growth) == [[pytest.approx(2.5, rel=1e-6), pytest.approx(6.5, rel=1e-6)]]
    out = _intervals(vals, -r, lambda v: -growth(v))  # stable outside: two intervals, each reaching a range end
    assert out[0] == [0.0, pytest.approx(2.5, rel=1e-6)] and out[1] == [pytest.approx(6.5, rel=1e-6), 10.0]


def test_a_failed_point_ends_the_interval_at_the_stable_grid_point():
    vals = np.array([1.0, 2.0, 3.0, 4.0])
    r = np.array([-1.0, -0.5, np.nan, -1.0])
    assert _intervals(vals, r, lambda v: 1 / 0) == [[1.0, 2.0], [4.0, 4.0]]

"""Grid-independent continuation of the statics sweep (analysis/studies/statics_study.py).

A sweep's points are each warm-started from the nearest node of a path that depends only on the
sweep's range, so a 100,000-point sweep takes the same continuation steps as a 1,000-point one.  The
hard place is psi1 ~ 1.2616, where the barrier flow through the saturated regulator valve reverses:
the square-root law's derivative is ~1e5 there and IPOPT stalls close to the root.  The compressor
failed at the same psi1 for another reason: 58,000 tiny warm-started steps drifted into a point that
IPOPT could not leave.
"""

import numpy as np
import pytest

from autobal.analysis.run.solver_options import defaults
from autobal.analysis.studies.statics_study import continuation

DENSE = np.linspace(0.25, 2.0, 100_000)  # the grid that failed at psi1 = 1.26162
AROUND = DENSE[(DENSE > 1.2605) & (DENSE < 1.2625)]


@pytest.mark.parametrize("device", ["pump", "compressor"])
def test_the_dense_grid_through_the_flow_reversal(request, device):
    solver = request.getfixturevalue(device)
    dpsi = solver.design.dpsi
    pts = continuation(solver, AROUND, dpsi, span=(0.25, 2.0))
    assert len(pts) == len(AROUND)
    assert max(p.max_residual for p in pts) < 1e-6
    # independent solves (each from its own closed-form start) agree
    for p in pts[::25]:
        cold = solver.solve(p.psi1, dpsi)
        assert np.allclose(p.x, cold.x, rtol=1e-7, atol=1e-9)
    if device == "pump":  # its barrier flow reverses in this window (why IPOPT stalls there)
        q_e = [p.flows["e"] for p in pts]
        assert min(q_e) < 0 < max(q_e)


def test_a_point_does_not_depend_on_the_other_requested_points(pump):
    dpsi = pump.design.dpsi
    some = AROUND[::7]
    together = continuation(pump, some, dpsi, span=(0.25, 2.0))
    alone = continuation(pump, some[3:4], dpsi, span=(0.25, 2.0))[0]
    np.testing.assert_array_equal(alone.x, together[3].x)


def test_a_coarse_grid_is_one_continuation_path(pump):
    """Up to continuation.path_nodes points the sweep is solved along the grid itself, as before."""
    grid = np.linspace(0.25, 2.0, 36)
    pts = continuation(pump, grid, pump.design.dpsi)
    assert [p.psi1 for p in pts] == list(grid) and len(grid) <= defaults["continuation.path_nodes"]
    seq = pump.sweep(grid, pump.design.dpsi)
    assert np.allclose(np.array([p.x for p in pts]), np.array([p.x for p in seq]), rtol=1e-9, atol=1e-12)

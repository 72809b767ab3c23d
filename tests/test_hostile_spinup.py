"""Spin-up values inside the schema's own bounds that used to crash or hang (issue #25 item 6): each is refused
before any solve with a one-line reason (exit 2), well within 20 s, without a traceback."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from autobal import cli

SCENES = Path(__file__).parent.parent / "scenarios"
JEFFCOTT = SCENES / "spinup_jeffcott_ramp_baselines.yaml"  # Omega0 = 105 rad/s, 40 -> 210 rad/s in 8.5 s

CASES = [
    # Omega0 = 1e7 rad/s: the critical speed 4.8e4 times the top speed (CVODES/IPOPT restoration failure before)
    ("stiffness_1e14", JEFFCOTT, "rotor.stiffness=1e14 N/m", "is 4.76e+04 times the highest speed 210 rad/s"),
    # the critical speed far above the speed range (the 52 s run of issue #25)
    ("critical_far_above", JEFFCOTT, "rotor.stiffness=1e7 N/m", "the spin-up never nears it"),
    # 1.7e7 natural periods: CVODES CV_TOO_MUCH_WORK with a traceback before
    ("horizon_1e6", JEFFCOTT, "analyses.spinup.horizon=1e6 s", "span 1.67e+07 natural periods"),
    ("settling_1e6", JEFFCOTT, "analyses.spinup.settling_time=1e6 s", "span 1.67e+07 natural periods"),
    # a passage at 1e-6 rad/s^2 would simulate 2.8e9 periods (a hang before)
    ("passage_1e-6", SCENES / "pashkov_runup.yaml", "analyses.rotor_dynamics.passage.acceleration=1e-6 rad/s^2",
     "analyses.rotor_dynamics.passage.acceleration: 1e-06 rad/s^2 takes 2.84e+09 natural periods"),
]


@pytest.mark.cli
@pytest.mark.parametrize("scene, override, text", [pytest.param(*c[1:], id=c[0]) for c in CASES])
def test_pathological_spinup_value_is_refused_quickly_in_one_line(tmp_path, capsys, scene, override, text):
    t0 = time.perf_counter()
    code = cli.main(["run", str(scene), "--out", str(tmp_path / "out"), "--quiet", "--set", override])
    elapsed = time.perf_counter() - t0
    err = capsys.readouterr().err
    assert code == 2, err
    lines = err.strip().splitlines()
    assert 1 <= len(lines) <= 3, err
    assert "Traceback" not in err and "CVODES" not in err
    assert text in err, err
    assert elapsed < 20, f"refusal took {elapsed:.1f} s (a hang?)"

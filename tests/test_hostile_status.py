"""Hostile scenes against the statuses and the trust model (issue #25, items 2 and 4).

A scene is data: it cannot name a dask scheduler (whose pickled results would run code in this process),
and it is refused before anything contacts a host.  Transient scenes drawn across the schema's bounds end
with exit 0, 2 or 3, never a traceback.
"""

from __future__ import annotations

import json
import socket

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import autobal
from autobal import scenario
from autobal.cli import main
from autobal.errors import ScenarioError


def with_executor(tmp_path, block) -> str:
    d = yaml.safe_load(scenario.resolve("pump_pe600_montecarlo").read_text())
    d["executor"] = block
    path = tmp_path / "hostile_scheduler.yaml"
    path.write_text(yaml.safe_dump(d))
    return str(path)


@pytest.mark.cli
def test_a_scene_naming_a_scheduler_is_refused_and_contacts_no_host(tmp_path, capsys):
    with socket.socket() as listener:  # a "scheduler" on loopback that records any connection
        listener.bind(("127.0.0.1", 0))
        listener.listen(1)
        listener.settimeout(0.3)
        path = with_executor(tmp_path, {"scheduler": f"tcp://127.0.0.1:{listener.getsockname()[1]}"})
        rc = main(["run", path, "--out", str(tmp_path / "o")])
        err = capsys.readouterr().err
        with pytest.raises(TimeoutError):
            listener.accept()
    assert rc == 2 and not (tmp_path / "o").exists()
    assert len(err.strip().splitlines()) == 1
    assert "executor: scheduler: a scene cannot name a scheduler" in err
    assert "--scheduler" in err and "AUTOBAL_SCHEDULER" in err
    assert main(["check", path]) == 2
    with pytest.raises(ScenarioError, match="a scene cannot name a scheduler"):
        autobal.load(path)
    with pytest.raises(ScenarioError, match="a scene cannot name a scheduler"):
        autobal.load("pump_pe600_montecarlo", set={"executor.scheduler": "tcp://127.0.0.1:8786"})
    # even an empty one, and the progress setting stays plain data
    with pytest.raises(ScenarioError, match="a scene cannot name a scheduler"):
        autobal.load(with_executor(tmp_path, {"scheduler": None}))
    assert autobal.load(with_executor(tmp_path, {"progress": False})).executor.progress is False


@st.composite
def transient_scenes(draw) -> dict:
    """The K180 compressor with a transient drawn within the schema's bounds (small durations and few points
    to keep the test short)."""
    d = yaml.safe_load(scenario.resolve("compressor_k180_dynamics").read_text())
    kind = draw(st.sampled_from(["force_step", "pressure_step", "pressure_harmonic"]))
    case = {"input": kind, "amplitude": draw(st.floats(-100, 100, allow_nan=False)),
            "thrust_follows_pressure": draw(st.booleans())}
    if kind == "pressure_harmonic" and draw(st.booleans()):
        case["frequency"] = f"{draw(st.floats(1e-9, 1e7)):.6g} rad/s"
    d["analyses"] = {"transient": {
        "operating_ratio": draw(st.sampled_from([0.2, 1.0, 1.5, 30.0, 1e6])),
        "model": draw(st.sampled_from(["nonlinear", "nonlinear_chain"])),
        "integrator": draw(st.sampled_from(["cvodes", "idas"])),
        "duration": f"{draw(st.sampled_from([1e-12, 1e-6, 1e-4, 2e-3])):g} s",
        "points": draw(st.integers(10, 40)),
        "cases": [case]}}
    return d


@pytest.mark.cli
@settings(max_examples=8, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(d=transient_scenes())
def test_transient_scenes_across_the_bounds_end_without_a_traceback(tmp_path, capsys, d):
    path = tmp_path / "drawn.yaml"
    path.write_text(yaml.safe_dump(d))
    out = tmp_path / "o"
    rc = main(["run", str(path), "-q", "--out", str(out)])
    err = capsys.readouterr().err
    assert rc in (0, 2, 3), err
    assert "Traceback" not in err
    if rc == 0:
        res = json.loads((out / "results.json").read_text())
        assert res["status"] == "ok" and not res["transient"]["failures"]
        assert all(c["failure"] is None for c in res["transient"]["cases"])
    elif rc == 3:
        assert err.startswith("autobal: solve failed: ")
        assert (out / "failed_solve.json").exists() or json.loads((out / "results.json").read_text())[
            "status"] == "failed"
    else:
        assert err.startswith("autobal: bad input: ") and len(err.strip().splitlines()) == 1

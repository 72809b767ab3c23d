"""Interrupts: SIGINT and SIGTERM during a spin-up IPOPT solve and during a Monte Carlo stop the run.

The contract (autobal/cli.py, autobal/output.py): exit code 130 (SIGINT) or 143 (SIGTERM), one line on
stderr, and an output folder that holds no results.json (it holds interrupted.json), or a results.json
whose status is "interrupted".  The solver trace (analysis/run/interrupt.py) says when a solve is under way.
"""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from autobal.analysis.run import interrupt
from autobal.errors import Interrupted


def interrupted_run(tmp_path: Path, scene: str, solver: str, sig: int, after: float = 0.05, extra=()):
    """Run ``autobal run scene`` (with the ``extra`` arguments), send ``sig`` ``after`` s after the first call of
    ``solver``; returns (exit code, stderr lines without CasADi's warnings, output folder, s from signal to exit)."""
    trace, out = tmp_path / "trace.txt", tmp_path / "out"
    env = os.environ | {"AUTOBAL_SOLVER_TRACE": str(trace)}
    # SIGINT at its default in the child, as on a terminal (a shell starts background jobs with SIGINT ignored)
    proc = subprocess.Popen([sys.executable, "-m", "autobal", "run", scene, "--out", str(out), *extra], cwd=tmp_path,
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 300
    while not (trace.exists() and solver in trace.read_text().split()):
        assert proc.poll() is None, f"the run ended before {solver} was called"
        assert time.monotonic() < deadline, f"{solver} never called"
        time.sleep(0.05)
    time.sleep(after)
    t0 = time.monotonic()
    proc.send_signal(sig)
    try:
        _, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    lines = [line for line in err.splitlines() if line.strip() and not line.startswith("CasADi - ")]
    return proc.returncode, lines, out, time.monotonic() - t0


def assert_interrupted(code, lines, out, seconds, expected_code, name):
    assert code == expected_code, lines
    assert not any("Traceback" in line for line in lines), lines
    assert lines == [f"autobal: interrupted ({name})"], lines
    results = out / "results.json"
    assert not results.exists() or json.loads(results.read_text())["status"] == "interrupted"
    assert json.loads((out / "interrupted.json").read_text())["status"] == "interrupted"
    assert seconds < 10, f"took {seconds:.1f} s to stop"


@pytest.mark.cli
@pytest.mark.slow
def test_sigint_during_the_spinup_ipopt_solve(tmp_path):
    code, lines, out, seconds = interrupted_run(tmp_path, "spinup_jeffcott_deadline_5s", "spinup", signal.SIGINT)
    assert_interrupted(code, lines, out, seconds, 130, "SIGINT")
    assert json.loads((out / "interrupted.json").read_text())["analysis"] == "spinup"


@pytest.mark.cli
@pytest.mark.slow
def test_sigint_during_the_monte_carlo(tmp_path):
    code, lines, out, seconds = interrupted_run(tmp_path, "pump_pe600_montecarlo", "call_rows", signal.SIGINT)
    assert_interrupted(code, lines, out, seconds, 130, "SIGINT")
    assert json.loads((out / "interrupted.json").read_text())["analysis"] == "montecarlo"


@pytest.mark.cli
@pytest.mark.slow
def test_sigterm_during_the_monte_carlo(tmp_path):
    code, lines, out, seconds = interrupted_run(tmp_path, "pump_pe600_montecarlo", "call_rows", signal.SIGTERM)
    assert_interrupted(code, lines, out, seconds, 143, "SIGTERM")


def test_an_interrupt_a_solver_swallowed_is_raised_after_the_call():
    """CasADi turns an interrupt inside IPOPT into a status; the recorded signal is raised after the call."""
    def swallowing_solver():
        try:
            signal.raise_signal(signal.SIGINT)  # the handler raises here, as inside IPOPT's callback
        except KeyboardInterrupt:
            pass  # ... and the solver swallows it, returning a status
        return "NonIpopt_Exception_Thrown"

    interrupt.clear()
    previous = signal.getsignal(signal.SIGINT)
    signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(Interrupted) as exc:
            interrupt.call(swallowing_solver)
        assert exc.value.signum == signal.SIGINT
        assert interrupt.requested() is None  # raised once
        assert interrupt.call(lambda: 42) == 42
    finally:
        signal.signal(signal.SIGINT, previous)
        interrupt.clear()


def test_an_interrupt_turned_into_a_solver_error_is_an_interrupt():
    def failing_solver():
        try:
            signal.raise_signal(signal.SIGINT)
        except KeyboardInterrupt:
            raise RuntimeError('CVode returned "CV_RHSFUNC_FAIL"') from None

    interrupt.clear()
    previous = signal.getsignal(signal.SIGINT)
    signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(Interrupted):
            interrupt.call(failing_solver)
    finally:
        signal.signal(signal.SIGINT, previous)
        interrupt.clear()


def test_a_handler_that_does_not_raise_is_not_an_interrupt():
    seen = []
    previous = signal.getsignal(signal.SIGINT)
    signal.signal(signal.SIGINT, lambda signum, frame: seen.append(signum))
    try:
        assert interrupt.call(lambda: signal.raise_signal(signal.SIGINT) or 7) == 7
        assert seen == [signal.SIGINT] and interrupt.requested() is None
    finally:
        signal.signal(signal.SIGINT, previous)
        interrupt.clear()

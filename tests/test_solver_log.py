"""autobal.log holds every IPOPT solve of its own run (iterations and status), and a run never takes the caller's
standard output and error (file descriptors 1 and 2, sys.stdout, sys.stderr) away, also with runs in threads."""

import os
import re
import sys
import threading

import pytest

import autobal
from autobal.analysis.numerics import ipopt
from autobal.analysis.run import solver_options
from autobal.errors import SolveError
from autobal.output import SolverLog

pytestmark = pytest.mark.cli  # end to end through autobal.run / the CLI


def _solves(log: str) -> list[tuple[str, str, str]]:
    """(solver, status, its IPOPT text) of each solve in an autobal.log."""
    parts = re.split(r"^--- IPOPT (\S+): (\S+), \S+ iterations\n", log, flags=re.M)
    texts = [t.split("\n=== ")[0] for t in parts[3::3]]  # the run's own lines follow its solves
    return list(zip(parts[1::3], parts[2::3], texts, strict=True))


SCENES = {"pump": "pump_pe600_statics", "compressor": "compressor_k180_statics"}


def in_threads(work) -> dict:
    """``work(name)`` for each scene of SCENES in a thread of its own, all at once; name -> what it returned."""
    out, errors = {}, []

    def one(name):
        try:
            out[name] = work(name)
        except BaseException as exc:  # noqa: BLE001 (reported below)
            errors.append(exc)

    threads = [threading.Thread(target=one, args=(name,)) for name in SCENES]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    return out


def assert_the_caller_keeps_its_output(capfd, stdout, stderr, fds) -> None:
    """sys.stdout, sys.stderr and file descriptors 1 and 2 are the caller's, and reach the caller."""
    assert sys.stdout is stdout and sys.stderr is stderr
    assert [(s.st_dev, s.st_ino) for s in (os.fstat(fd) for fd in (1, 2))] == [(s.st_dev, s.st_ino) for s in fds]
    os.write(1, b"caller's line on fd 1\n")
    os.write(2, b"caller's line on fd 2\n")
    print("caller's print")
    out, err = capfd.readouterr()
    assert out == "caller's line on fd 1\ncaller's print\n" and err == "caller's line on fd 2\n"  # no solver text


def assert_solved_statics_log(log: str) -> None:
    solves = _solves(log)
    assert len(solves) > 10
    for solver, status, text in solves:
        assert solver in {"statics", "statics_warm", "force_gap", "critical"}
        assert "iter    objective" in text and status == "Solve_Succeeded"
        assert text.rstrip().endswith("EXIT: Optimal Solution Found.")


def test_solves_in_two_threads_go_to_the_log_of_their_own_run(tmp_path, capfd):
    stdout, stderr, fds = sys.stdout, sys.stderr, [os.fstat(fd) for fd in (1, 2)]

    def run(name):
        with SolverLog(tmp_path / f"{name}.log"):
            return autobal.run(SCENES[name])

    in_threads(run)
    assert_the_caller_keeps_its_output(capfd, stdout, stderr, fds)
    logs = {name: (tmp_path / f"{name}.log").read_text() for name in SCENES}
    for log in logs.values():
        assert_solved_statics_log(log)
    # each log holds its own run's solves, no more, no fewer: the same solves, iterate for iterate, as a run alone
    for name in SCENES:
        alone = []
        with ipopt.logging_to(alone.append):
            autobal.run(SCENES[name])
        assert [(s, st, _iterations(t)) for s, st, t in _solves(logs[name])] == [
            (s, st, _iterations(t)) for s, st, t in _solves("".join(alone))]
    assert _iterations(_solves(logs["pump"])[0][2]) != _iterations(_solves(logs["compressor"])[0][2])


@pytest.mark.slow
@pytest.mark.cli
def test_two_runs_with_output_folders_in_two_threads_each_log_their_own_solves(tmp_path, capfd):
    stdout, stderr, fds = sys.stdout, sys.stderr, [os.fstat(fd) for fd in (1, 2)]
    runs = in_threads(lambda name: autobal.run(SCENES[name], out=tmp_path / name))
    assert_the_caller_keeps_its_output(capfd, stdout, stderr, fds)
    for name in SCENES:
        log = (tmp_path / name / "autobal.log").read_text()
        assert_solved_statics_log(log)
        assert f"=== statics: ok ({runs[name].timing['statics']:.2f} s)" in log


def _iterations(text: str) -> list[str]:
    """The rows of IPOPT's iteration table (without the timing lines, which differ between runs)."""
    return re.findall(r"^ *\d+r? +[-+]?\d\.\d+e[-+]\d+ .*$", text, flags=re.M)


def test_a_failed_solve_leaves_its_status_in_the_log(tmp_path, monkeypatch, capfd):
    monkeypatch.setitem(solver_options.defaults, "ipopt.max_iter", 1)
    with pytest.raises(SolveError) as err:
        autobal.run("compressor_k180_statics", out=tmp_path / "x")
    log = (tmp_path / "x" / "autobal.log").read_text()
    solver, status, text = _solves(log)[-1]
    assert status == err.value.status == "Maximum_Iterations_Exceeded"
    assert "EXIT: Maximum Number of Iterations Exceeded." in text
    assert f"=== statics: solve failed, status Maximum_Iterations_Exceeded: {err.value}" in log
    assert capfd.readouterr() == ("", "")  # nothing of the solver on the caller's terminal


def test_a_run_without_an_output_folder_writes_no_log_and_prints_nothing(tmp_path, capfd, monkeypatch):
    monkeypatch.chdir(tmp_path)
    autobal.run("pump_pe600_statics")
    assert capfd.readouterr() == ("", "")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_an_integrator_failure_is_in_the_log(tmp_path, capfd):
    """CVODES stops at t = 0 with CV_TOO_MUCH_WORK on the undamped compressor's force step of 100
    (tests/test_status.py): the run's log says which case failed and with what status; nothing of it reaches the
    caller's terminal."""
    from tests.test_status import failing_transient

    run = autobal.run(failing_transient(tmp_path), out=tmp_path / "o")
    log = (tmp_path / "o" / "autobal.log").read_text()
    [line] = [x for x in log.splitlines() if x.startswith("=== transient")]
    assert run.status == "failed" and line.startswith("=== transient: failed: case 1 (force_step, amplitude 100)")
    assert "CV_TOO_MUCH_WORK" in line
    assert capfd.readouterr() == ("", "")


def test_casadi_messages_of_a_solver_call_go_to_the_runs_log_and_the_streams_come_back(capfd):
    """CasADi prints an integrator's failure (a NaN in the right-hand side) through Python's sys.stderr: within a
    run's log (solver_output.logging_to) that text goes to the log, not to the caller, and the caller's streams are
    the same objects afterwards; without a run log it reaches the caller as before."""
    import casadi as ca

    from autobal.analysis.run import interrupt, solver_output

    x = ca.SX.sym("x")
    F = ca.integrator("F", "cvodes", {"x": x, "ode": ca.sqrt(x)}, 0, 1)
    streams, logged = (sys.stdout, sys.stderr), []
    with solver_output.logging_to(logged.append), pytest.raises(SolveError):
        interrupt.call(F, x0=-1)
    assert (sys.stdout, sys.stderr) == streams
    assert "NaN detected" in "".join(logged)
    assert capfd.readouterr() == ("", "")
    with pytest.raises(SolveError):
        interrupt.call(F, x0=-1)
    assert "NaN detected" in capfd.readouterr().err

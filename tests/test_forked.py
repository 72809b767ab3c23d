"""Work shared with a forked process (analysis/run/forked.py): the results in order and those of one process, the
helper's exceptions and log raised and logged here, nothing of it on the terminal, a helper that dies replaced by
this process, and none left running after an interrupt."""

import os
import subprocess
import sys
import textwrap
import time

import pytest

import autobal
from autobal.analysis.run import forked, solver_output

TWO = len(os.sched_getaffinity(0)) >= 2 if hasattr(os, "sched_getaffinity") else False
needs_two = pytest.mark.skipif(not (TWO and sys.platform.startswith("linux")), reason="needs fork and two cores")


def slow_square(i):
    time.sleep(0.05)
    return i * i, os.getpid()


@needs_two
def test_shared_gives_the_results_in_order_and_the_helper_takes_some():
    out = forked.shared(slow_square, 8)
    assert [v for v, _ in out] == [i * i for i in range(8)]
    pids = {p for _, p in out}
    assert os.getpid() in pids and len(pids) == 2  # this process and its helper each took some
    with autobal.using_solver_defaults("parallel", processes=1):
        assert forked.processes() == 1
        assert {p for _, p in forked.shared(slow_square, 4)} == {os.getpid()}


@needs_two
def test_an_exception_of_the_helper_is_raised_here():
    def fail_in_helper(i):
        raise ValueError(f"task {i} failed in the helper")

    with pytest.raises(ValueError, match="failed in the helper"):
        forked.shared(lambda i: time.sleep(0.5), 3, fail_in_helper)


@needs_two
def test_what_a_dead_helper_did_not_send_is_computed_here():
    def die(i):
        os._exit(3)

    assert [v for v, _ in forked.shared(slow_square, 5, die)] == [0, 1, 4, 9, 16]


@needs_two
def test_a_result_larger_than_the_pipe_does_not_hold_the_helper_up():
    def big(i):  # 1 MB each: the helper goes on to its next task while this process works on its own
        time.sleep(0.1)
        return bytes(1 << 20), os.getpid()

    out = forked.shared(big, 8)
    assert sum(1 for _, p in out if p != os.getpid()) >= 2  # held up, the helper would have done one


@needs_two
def test_the_helpers_log_goes_to_the_run_log_and_nothing_to_the_terminal(capfd):
    def helper(i):  # as long as this process's task: each side takes one of the two
        time.sleep(0.2)
        print("helper noise")
        os.write(2, b"helper fd noise\n")
        solver_output.log(f"helper log {i}")
        return i

    lines = []
    with solver_output.logging_to(lines.append):
        assert forked.shared(lambda i: (time.sleep(0.2), i)[1], 2, helper) == [0, 1]
    assert len([t for t in lines if t.startswith("helper log")]) == 1  # the task the helper took (either)
    out, err = capfd.readouterr()
    assert "noise" not in out + err


@needs_two
def test_later_computes_in_another_process_and_ends_it():
    with forked.Later(lambda: os.getpid()) as later:
        pid = later.result()
    assert pid != os.getpid()
    assert not os.path.exists(f"/proc/{pid}")  # reaped
    with autobal.using_solver_defaults("parallel", processes=1), forked.Later(lambda: os.getpid()) as later:
        assert later.result() == os.getpid()


@needs_two
@pytest.mark.parametrize("here", ["time.sleep(60)", "time.sleep(0.3)"])  # at work on its own task, or waiting
def test_an_interrupt_here_stops_at_once_and_kills_the_helper(tmp_path, here):
    script = textwrap.dedent(f"""
        import os, time
        from autobal.analysis.run import forked, interrupt
        interrupt.install(None)
        def helper(i):
            open({str(tmp_path / "pid")!r}, "w").write(str(os.getpid()))
            time.sleep(60)
        forked.shared(lambda i: {here}, 2, helper)
    """)
    proc = subprocess.Popen([sys.executable, "-c", script], stderr=subprocess.PIPE)
    pid_file = tmp_path / "pid"
    for _ in range(200):
        if pid_file.exists() and pid_file.read_text():
            break
        time.sleep(0.05)
    helper = int(pid_file.read_text())
    time.sleep(0.5)  # this process now at its own task (60 s) or waiting for the helper's (after 0.3 s)
    t0 = time.perf_counter()
    proc.terminate()
    proc.wait(timeout=10)
    assert time.perf_counter() - t0 < 2 and proc.returncode != 0
    assert not os.path.exists(f"/proc/{helper}")  # killed and reaped before the process ended


@needs_two
def test_without_a_process_to_fork_the_work_is_done_here(monkeypatch):
    def no_fork():
        raise BlockingIOError(11, "Resource temporarily unavailable")

    monkeypatch.setattr(forked.os, "fork", no_fork)
    assert forked.shared(slow_square, 3) == [(i * i, os.getpid()) for i in range(3)]
    with forked.Later(lambda: os.getpid()) as later:
        assert later.result() == os.getpid()

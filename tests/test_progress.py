"""Progress bars (analysis/run/progress.py): drawn on a terminal, silent on a pipe and with --quiet."""

import io
import signal

import casadi as ca
import numpy as np
import pytest

from autobal import scenario
from autobal.analysis.numerics import ipopt
from autobal.analysis.numerics.linearize import Setup
from autobal.analysis.numerics.stability import max_real
from autobal.analysis.run import interrupt, progress
from autobal.cli import main
from autobal.errors import Interrupted
from autobal.parts import device as device_part


class FakeTty(io.StringIO):
    def isatty(self):
        return True


@pytest.fixture
def tty():
    out = FakeTty()
    progress.set_stream(out)
    yield out
    progress.set_stream(None)
    progress.set_quiet(False)


def test_bar_on_a_terminal_counts_the_ticks(tty):
    with progress.steps(4, "sweep", "point", catch=True) as bar:
        for _ in range(3):
            bar.tick()
        progress.tick(note="last")  # the innermost open bar counts ticks from inside
        with progress.steps(2, "tasks") as inner:
            progress.tick()  # a bar without catch ignores them
    assert bar.count == 4 and inner.count == 0
    text = tty.getvalue()
    assert "sweep" in text and "/4 " in text and "point" in text


def test_no_bar_on_a_pipe_or_when_quiet(tty):
    pipe = io.StringIO()
    progress.set_stream(pipe)
    with progress.steps(3, "sweep") as bar:
        bar.tick(3)
    assert pipe.getvalue() == "" and bar.count == 3
    progress.set_stream(tty)
    progress.set_quiet(True)
    with progress.steps(3, "sweep") as bar:
        bar.tick(3)
    assert tty.getvalue() == ""


def test_tick_without_a_bar_does_nothing_and_output_keeps_an_explicit_stream(tty):
    progress.tick()  # no bar open: no error, nothing written
    with progress.output(io.StringIO()):
        assert progress.stream() is tty
    progress.set_stream(None)
    other = FakeTty()
    with progress.output(other):
        assert progress.stream() is other
    assert progress.stream() is not other
    assert tty.getvalue() == ""


def rosenbrock():
    """An IPOPT solver of the chained Rosenbrock function in 30 variables (about 60 iterations from -1.2)."""
    x = ca.SX.sym("x", 30)
    f = sum((1 - x[i]) ** 2 + 100 * (x[i + 1] - x[i] ** 2) ** 2 for i in range(29))
    return ipopt.nlpsol("rosenbrock", x, ca.SX.sym("p", 0), f, ca.SX(0, 1))


@pytest.fixture
def ticks(monkeypatch):
    """Every tick of every bar as (bar label, count after the tick, note); bars are drawn at once."""
    seen, tick = [], progress.Steps.tick
    monkeypatch.setattr(progress, "AFTER_S", 0.0)

    def record(self, n=1, note=""):
        tick(self, n, note)
        seen.append((self._bar.desc if self._bar is not None else None, self.count, note))

    monkeypatch.setattr(progress.Steps, "tick", record)
    return seen


def test_a_single_long_solve_advances_its_bar_per_iteration(tty, ticks):
    solver = rosenbrock()  # built on a terminal: it carries the iteration callback
    with progress.steps(None, "study", "IPOPT solve", catch=True) as outer:
        res = ipopt.solve(solver, x0=np.full(30, -1.2), lbg=[], ubg=[])
    assert res["success"] and res["iterations"] > 30
    inner = [(count, note) for desc, count, note in ticks if desc == "IPOPT rosenbrock"]
    counts = sorted({c for c, _ in inner})
    assert counts == list(range(res["iterations"] + 1))  # one step per IPOPT iteration, to the last one
    assert any(note.startswith("f 20352.2, inf_pr 0.0e+00") for _, note in inner)  # iteration 0's objective
    assert outer.count == 1  # the outer bar counts the solve, once
    assert "IPOPT rosenbrock" in tty.getvalue() and "iteration" in tty.getvalue()


def test_a_quiet_solve_has_no_callback_and_draws_nothing(tty, ticks):
    progress.set_quiet(True)
    solver = rosenbrock()
    assert getattr(solver, "autobal_iterations", None) is None  # quiet runs pay nothing per iteration
    res = ipopt.solve(solver, x0=np.full(30, -1.2), lbg=[], ubg=[])
    assert res["success"] and tty.getvalue() == "" and all(desc is None for desc, _, _ in ticks)
    progress.set_quiet(False)
    solver = rosenbrock()
    progress.set_quiet(True)  # built on a terminal, solved quietly: no bar either
    ipopt.solve(solver, x0=np.full(30, -1.2), lbg=[], ubg=[])
    assert tty.getvalue() == ""


def test_an_interrupt_during_a_solve_with_a_bar_stops_it_at_once(tty, ticks, monkeypatch):
    solver = rosenbrock()
    tick = progress.Steps.tick

    def interrupt_at_5(self, n=1, note=""):
        tick(self, n, note)
        if self.count == 5 and n:
            signal.raise_signal(signal.SIGINT)

    monkeypatch.setattr(progress.Steps, "tick", interrupt_at_5)
    # Python's own SIGINT handler, as on a terminal (a shell starts background jobs with SIGINT ignored)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(Interrupted):
            ipopt.solve(solver, x0=np.full(30, -1.2), lbg=[], ubg=[])
    finally:
        signal.signal(signal.SIGINT, previous)
    assert solver.stats()["iter_count"] <= 6 and solver.stats()["return_status"] == "User_Requested_Stop"
    assert interrupt.requested() is None


def test_a_stability_map_grid_shows_its_bar(tty, ticks):
    setup = Setup(device_part.adapt(scenario.load("pump_pe600_simplified").device))
    r = max_real(setup, "program", [{"V2": v} for v in (1e-5, 2e-5, 4e-5)])
    assert r.shape == (3,)
    assert [c for desc, c, _ in ticks if desc == "max Re lambda, program model"] == [1, 2, 3]


SMALL_RELIABILITY = ["--set", "analyses.reliability.tau_nodes=101", "--set", "analyses.reliability.time_points=201"]


@pytest.mark.cli
@pytest.mark.parametrize("mode", ["terminal", "quiet", "pipe"])
def test_cli_run_shows_the_reliability_bar_on_a_terminal_only_without_quiet(tty, tmp_path, capsys, mode):
    """The hydroheel reliability (about a minute at the scene's quadrature) shows its bar on a terminal;
    nothing with --quiet, nothing on a pipe (the summaries still print there)."""
    out = tty if mode != "pipe" else io.StringIO()
    progress.set_stream(out)
    args = ["run", "hydroheel_wear", "--out", str(tmp_path / "out"), *SMALL_RELIABILITY]
    args += ["--quiet"] if mode == "quiet" else []
    assert main(args) == 0
    printed = capsys.readouterr().out
    if mode == "terminal":
        assert "reliability (P(t), MTTF, t(P), accuracy)" in out.getvalue() and "/9 " in out.getvalue()
    else:
        assert out.getvalue() == ""
        assert (printed == "") == (mode == "quiet")
    assert progress.enabled(tty)  # --quiet lasts for its run only

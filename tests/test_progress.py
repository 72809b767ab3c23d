"""Progress bars (analysis/progress.py): drawn on a terminal, silent on a pipe and with --quiet."""

import io

import pytest

from autobal.analysis import progress
from autobal.cli import main


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

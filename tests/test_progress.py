"""Progress bars (analysis/progress.py): drawn on a terminal, silent on a pipe and with --quiet."""

import io

import pytest

from autobal.analysis import progress


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
    with progress.steps(4, "sweep", "point") as bar:
        for _ in range(3):
            bar.tick()
        progress.tick(note="last")  # the innermost open bar
    assert bar.count == 4
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

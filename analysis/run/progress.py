"""Progress bars of long analyses (tqdm), one small interface for all of them.

>>> with steps(len(points), "statics sweep") as bar:
...     for p in points:
...         solve(p)
...         bar.tick()

A bar is drawn only on a terminal and not when quiet (``autobal --quiet``): off a terminal (a pipe,
a file, a test's captured stream) nothing is written.  Bars go to standard error, or to the stream
:func:`output` names (a run that sends solver output to ``autobal.log`` keeps the terminal for them).
Code deep inside an analysis that does not own the bar calls the module's :func:`tick` (every IPOPT
solve does, analysis/numerics/ipopt.py): it advances the innermost open bar if that bar was opened with
``catch=True`` (a bar that counts solves, e.g. the spin-up's starts), and does nothing otherwise (no
bar, or a bar that counts its own steps, such as a Monte Carlo's tasks).  A bar opened with ``delay``
is drawn only once its work has lasted that long (``delay=AFTER_S``: an IPOPT solve's iteration bar,
a stability map, a frequency sweep; short work draws nothing).
"""

from __future__ import annotations

import contextlib
import sys
import threading

from tqdm import tqdm

AFTER_S = 1.0  # work whose length is not known in advance opens its bar with this delay, s
_STATE: dict = {"stream": None, "quiet": False, "open": []}


def set_quiet(quiet: bool) -> None:
    """No bars at all (the CLI's ``--quiet``)."""
    _STATE["quiet"] = bool(quiet)


def silence() -> None:
    """No bars from now on, and the bars open now are left alone (in a forked helper process they are its
    parent's: analysis/run/forked.py)."""
    _STATE["quiet"] = True
    _STATE["open"] = []


def set_stream(stream) -> None:
    """Where bars go; None: standard error."""
    _STATE["stream"] = stream


def stream():
    """The stream bars go to now."""
    return _STATE["stream"] or sys.stderr


@contextlib.contextmanager
def output(terminal):
    """Within the block, bars go to ``terminal`` unless a stream was set explicitly (:func:`set_stream`)."""
    if _STATE["stream"] is not None:
        yield
        return
    _STATE["stream"] = terminal
    try:
        yield
    finally:
        _STATE["stream"] = None


def enabled(out=None) -> bool:
    """Whether a bar is drawn: not quiet, in the main thread (a solve in a helper thread, such as the spin-up's
    coarse screening's, draws nothing), and ``out`` (default: the current stream) is a terminal."""
    if threading.current_thread() is not threading.main_thread():
        return False
    out = out or stream()
    try:
        return not _STATE["quiet"] and bool(out.isatty())
    except (AttributeError, ValueError):  # closed or not a file
        return False


class Steps:
    """One bar: ``tick(n=1, note="")`` after each step; ``count`` is the steps ticked so far."""

    def __init__(self, total: int | None, desc: str, unit: str = "step", show: bool = True, catch: bool = False,
                 delay: float = 0.0):
        self.catch = catch
        self.count = 0
        self._bar = None
        if show and enabled():
            counter = "{desc}: {n_fmt} " + unit + "s, {elapsed}{postfix}" if total is None else None
            self._bar = tqdm(total=total, desc=desc, unit=unit, file=stream(), leave=False, dynamic_ncols=True,
                             bar_format=counter, delay=delay)

    def tick(self, n: int = 1, note: str = "") -> None:
        self.count += n
        if self._bar is not None:
            if note:
                self._bar.set_postfix_str(note, refresh=False)
            self._bar.update(n)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None


@contextlib.contextmanager
def steps(total: int | None, desc: str, unit: str = "step", show: bool = True, catch: bool = False,
          delay: float = 0.0):
    """A bar of ``total`` steps (None: a counter with elapsed time) labelled ``desc``.

    Parameters
    ----------
    total : int or None
        Number of steps; None when not known in advance (the bar counts and shows the elapsed time).
    desc : str
        Label, e.g. ``"stability map"``.
    unit : str
        What a step is (``"point"``, ``"solve"``, ``"task"``).
    show : bool
        False: no bar whatever the stream (a caller's own switch, e.g. a scene's ``progress: false``).
    catch : bool
        The bar also counts the module-level :func:`tick` calls made inside it (IPOPT solves).
    delay : float
        Draw the bar only once it has been open this long, s (0: at once).

    Yields
    ------
    Steps
        Call ``tick()`` after each step.
    """
    bar = Steps(total, desc, unit, show, catch, delay)
    _STATE["open"].append(bar)
    try:
        yield bar
    finally:
        _STATE["open"].remove(bar)
        bar.close()


def tick(n: int = 1, note: str = "") -> None:
    """Advance the innermost open bar if it was opened with ``catch=True`` (else nothing)."""
    if _STATE["open"] and _STATE["open"][-1].catch:
        _STATE["open"][-1].tick(n, note)

"""Interrupts (SIGINT, SIGTERM) that no solver swallows.

CasADi checks for signals inside IPOPT, CVODES and its rootfinders and turns the KeyboardInterrupt raised
there into a solver status ("NonIpopt_Exception_Thrown"), a RuntimeError ("CV_RHSFUNC_FAIL") or a
SystemError, after which a study would carry on or fail with the wrong message.  Here the signal handler
records the signal before raising, and :func:`check`, called after every solver call
(:func:`autobal.analysis.ipopt.solve`, :func:`call`), raises :class:`Interrupted` whatever the solver made
of it.  A run layer catching any exception can ask :func:`requested` whether it was an interrupt.

The handlers are installed by the run layer (:func:`install`); SIGINT is also taken over at the first
solver call when it still has Python's default handler (:func:`ensure`), which behaves as before
(KeyboardInterrupt) and records the signal.
"""

from __future__ import annotations

import os
import signal
import sys
import threading

EXIT_CODES = {signal.SIGINT: 130, signal.SIGTERM: 143}  # 128 + signal number, as a shell reports them
_state = {"signum": None, "watchdog": None}


class Interrupted(KeyboardInterrupt):
    """The run was interrupted by ``signum`` (SIGINT or SIGTERM); exit code 128 + signum."""

    def __init__(self, signum: int):
        super().__init__(f"interrupted by {signal.Signals(signum).name}")
        self.signum = signum

    @property
    def exit_code(self) -> int:
        return EXIT_CODES.get(self.signum, 128 + self.signum)


def _handler(signum, frame):
    first = _state["signum"] is None
    _state["signum"] = signum
    if first and _state["watchdog"] is not None:
        threading.Thread(target=_watchdog, args=(signum, _state["watchdog"]), daemon=True).start()
    raise Interrupted(signum)


def _watchdog(signum: int, seconds: float) -> None:
    """Last resort: a solver that keeps running ``seconds`` after the signal ends the process."""
    threading.Event().wait(seconds)
    sys.stderr.write(f"autobal: interrupted by {signal.Signals(signum).name}; a solver did not stop, "
                     f"exiting\n")
    sys.stderr.flush()
    os._exit(EXIT_CODES.get(signum, 128 + signum))


def install(watchdog_s: float | None = 2.0) -> None:
    """Install the SIGINT and SIGTERM handlers (main thread only; elsewhere nothing happens).

    Parameters
    ----------
    watchdog_s : float or None
        After a signal, end the process if it has not stopped within this many seconds, s;
        None: never.
    """
    if threading.current_thread() is not threading.main_thread():
        return
    _state["watchdog"] = watchdog_s
    signal.signal(signal.SIGINT, _handler)
    signal.signal(signal.SIGTERM, _handler)


def ensure() -> None:
    """Take over SIGINT if it still has Python's default handler (main thread only)."""
    if (threading.current_thread() is threading.main_thread()
            and signal.getsignal(signal.SIGINT) is signal.default_int_handler):
        signal.signal(signal.SIGINT, _handler)


def requested() -> int | None:
    """The signal number of an interrupt received since the last :func:`clear`, else None."""
    return _state["signum"]


def clear() -> None:
    """Forget a received interrupt (tests, or a caller that handled it)."""
    _state["signum"] = None


def check() -> None:
    """Raise :class:`Interrupted` if a signal arrived, whatever a solver made of it."""
    if _state["signum"] is not None:
        raise Interrupted(_state["signum"])


def call(function, *args, **kwargs):
    """``function(*args, **kwargs)`` (a CasADi solver, integrator or rootfinder) with :func:`check` after it,
    also when it raised: an interrupt turned into a solver error is an interrupt."""
    ensure()
    check()
    try:
        out = function(*args, **kwargs)
    except BaseException:
        check()
        raise
    check()
    return out

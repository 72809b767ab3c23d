"""Where what the solvers print goes: the log of the run they belong to.

A run (``autobal.output.SolverLog``) names its log with :func:`logging_to`, a context variable, so runs in several
threads each keep their own.  IPOPT writes its iteration log into a file of its own (analysis/numerics/ipopt.py), which
:func:`log` appends; CasADi prints its warnings and the integrators' failure messages (CVODES, IDAS) through
Python's ``sys.stdout`` and ``sys.stderr``, which :func:`captured` routes to the log for the duration of one solver
call (analysis/run/interrupt.py ``call``).  Nothing of the process is redirected: file descriptors 1 and 2 are never
touched, and while any solver call of a run is under way ``sys.stdout``/``sys.stderr`` are stand-ins that pass
everything of other threads and contexts on to the streams they replace, which they are again afterwards.
"""

from __future__ import annotations

import contextlib
import sys
import threading
from collections.abc import Callable
from contextvars import ContextVar

#: where the solver output of this run goes (:func:`logging_to`); None: nowhere (the caller's streams)
_RUN_LOG: ContextVar[Callable[[str], None] | None] = ContextVar("autobal_run_log", default=None)
#: whether this context is inside a solver call of a run (:func:`captured`)
_IN_SOLVER: ContextVar[bool] = ContextVar("autobal_in_solver", default=False)
_LOCK = threading.Lock()
_STATE = {"calls": 0, "streams": None}  # solver calls under way, the streams the stand-ins replace


@contextlib.contextmanager
def logging_to(write: Callable[[str], None]):
    """Within the block (in this thread or task), what the solvers print goes to ``write``: IPOPT's log of each
    solve (:func:`log`) and CasADi's messages during a solver call (:func:`captured`)."""
    token = _RUN_LOG.set(write)
    try:
        yield
    finally:
        _RUN_LOG.reset(token)


def logging() -> bool:
    """Whether a run's log takes the solver output in this context (:func:`logging_to`)."""
    return _RUN_LOG.get() is not None


def log(text: str) -> None:
    """Add ``text`` to the log of the run in progress (:func:`logging_to`), if there is one."""
    write = _RUN_LOG.get()
    if write is not None:
        write(text)


class _Stream:
    """A stand-in for ``sys.stdout`` or ``sys.stderr``: a context inside a solver call of a run writes to the run's
    log, every other context to the stream it replaces."""

    def __init__(self, stream):
        self.stream = stream

    def write(self, text: str) -> int:
        write = _RUN_LOG.get() if _IN_SOLVER.get() else None
        if write is None:
            return self.stream.write(text)
        if text.strip():
            write(text)
        return len(text)

    def flush(self) -> None:
        self.stream.flush()

    def __getattr__(self, name):
        return getattr(self.stream, name)


@contextlib.contextmanager
def captured():
    """Within the block (one solver call), what CasADi prints through ``sys.stdout``/``sys.stderr`` in this context
    goes to the run's log; without a run (:func:`logging_to`) the block changes nothing."""
    if _RUN_LOG.get() is None or _IN_SOLVER.get():
        yield
        return
    with _LOCK:
        if _STATE["calls"] == 0:
            _STATE["streams"] = (sys.stdout, sys.stderr)
            sys.stdout, sys.stderr = _Stream(sys.stdout), _Stream(sys.stderr)
        _STATE["calls"] += 1
    token = _IN_SOLVER.set(True)
    try:
        yield
    finally:
        _IN_SOLVER.reset(token)
        with _LOCK:
            _STATE["calls"] -= 1
            if _STATE["calls"] == 0:
                sys.stdout, sys.stderr = _STATE["streams"]
                _STATE["streams"] = None

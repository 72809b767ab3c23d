"""Interrupts (SIGINT, SIGTERM) that no solver swallows.

CasADi checks for signals inside IPOPT, CVODES and its rootfinders; the KeyboardInterrupt (or
:class:`autobal.errors.Interrupted`) that the Python signal handler raises there is turned into a solver
status ("NonIpopt_Exception_Thrown"), a RuntimeError ("CV_RHSFUNC_FAIL") or a SystemError, after which a
study would carry on, or fail with the wrong message.  Here every raising signal handler is wrapped so
that the signal is recorded, and :func:`call`, through which the solvers are called (IPOPT by
:func:`autobal.analysis.numerics.ipopt.solve`), raises :class:`~autobal.errors.Interrupted` after the call
whatever the solver made of the signal.

The wrapping (:func:`ensure`) happens at the first solver call and keeps each handler's behaviour
(Python's default SIGINT handler still raises KeyboardInterrupt; a run layer's SIGTERM handler still
raises what it raises); a handler that does not raise is not an interrupt.  A run layer may call
:func:`install` instead: both signals then raise Interrupted, and a watchdog ends a process whose
solver has not stopped 2 s after the signal.
"""

from __future__ import annotations

import os
import pickle
import re
import signal
import sys
import threading

from autobal.analysis.run import solver_output
from autobal.errors import Interrupted, SolverFailure

SIGNALS = (signal.SIGINT, signal.SIGTERM)
_state = {"signum": None, "watchdog": None}


def _raise(signum, frame):
    raise Interrupted(signum)


def _wrap(previous):
    """A handler that records the signal when ``previous`` raises (the interrupt), then re-raises."""

    def handler(signum, frame):
        try:
            previous(signum, frame)
        except BaseException:
            first = _state["signum"] is None
            _state["signum"] = signum
            if first and _state["watchdog"] is not None:
                threading.Thread(target=_watchdog, args=(signum, _state["watchdog"]), daemon=True).start()
            raise

    handler.autobal_wrapped = True
    return handler


def _watchdog(signum: int, seconds: float) -> None:
    """Last resort: a solver still running ``seconds`` after the signal ends the process."""
    threading.Event().wait(seconds)
    sys.stderr.write(f"autobal: interrupted ({signal.Signals(signum).name}); a solver did not stop, exiting\n")
    sys.stderr.flush()
    os._exit(128 + signum)


def _main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


def install(watchdog_s: float | None = 2.0) -> None:
    """Make SIGINT and SIGTERM raise :class:`~autobal.errors.Interrupted` (main thread only).

    Parameters
    ----------
    watchdog_s : float or None
        After a signal, end the process (exit code 128 + signal) if it has not stopped within this
        many seconds, s; None: never.
    """
    if not _main_thread():
        return
    _state["watchdog"] = watchdog_s
    for sig in SIGNALS:
        signal.signal(sig, _wrap(_raise))


def ensure() -> None:
    """Wrap the current SIGINT and SIGTERM handlers that are Python functions (main thread only)."""
    if not _main_thread():
        return
    for sig in SIGNALS:
        current = signal.getsignal(sig)
        if callable(current) and not getattr(current, "autobal_wrapped", False):
            signal.signal(sig, _wrap(current))


def requested() -> int | None:
    """The number of the signal that interrupted the run and that no :func:`check` has raised yet, else None."""
    return _state["signum"]


def clear() -> None:
    """Forget a received interrupt (a caller that handled it, or tests)."""
    _state["signum"] = None


def check() -> None:
    """Raise :class:`~autobal.errors.Interrupted` (once) if a signal interrupted the run."""
    signum, _state["signum"] = _state["signum"], None
    if signum is not None:
        raise Interrupted(signum)


def call(function, *args, **kwargs):
    """``function(*args, **kwargs)`` (a CasADi solver, integrator or rootfinder), then :func:`check`,
    also when it raised: an interrupt turned into a solver error or status is an interrupt.  With the
    environment variable ``AUTOBAL_SOLVER_TRACE`` set to a file, the solver's name is appended to it first.

    Returns
    -------
    What ``function`` returns.
    """
    ensure()
    check()
    _trace(function)
    try:
        with solver_output.captured():  # CasADi's messages (a failed integrator's) go to the run's log
            out = function(*args, **kwargs)
    except RuntimeError as exc:
        check()
        if type(exc) is not RuntimeError:  # ours (a SolveError), or Python's RecursionError, NotImplementedError
            raise
        raise _failure(function, exc) from exc
    except BaseException:
        check()
        raise
    check()
    return out


def _name(function) -> str:
    """The name of a CasADi function, or of a Python callable ("solver" for one without a name)."""
    return function.name() if callable(getattr(function, "name", None)) else getattr(function, "__name__", "solver")


def _trace(function) -> None:
    """With the environment variable ``AUTOBAL_SOLVER_TRACE`` set to a file, append the name of ``function`` to it
    (tests wait on it to interrupt a solve)."""
    trace = os.environ.get("AUTOBAL_SOLVER_TRACE")
    if trace:
        with open(trace, "a") as fh:
            fh.write(f"{_name(function)}\n")


def _blas_limit() -> dict:
    """The environment that gives a new process this process's BLAS thread limit (threadpoolctl's view)."""
    from threadpoolctl import threadpool_info

    n = min((i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"), default=None)
    return {} if n is None else {k: str(n) for k in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}


def answer(function, args, fd: int) -> None:
    """Compute ``function(*args)`` and write ``(True, value)`` or ``(False, exception)`` pickled to the file
    descriptor ``fd`` (the child's side of :func:`isolated`)."""
    try:
        out = (True, function(*args))
    except BaseException as exc:  # noqa: BLE001 - raised again in the parent
        out = (False, exc)
    try:
        data = pickle.dumps(out)
        pickle.loads(data)  # noqa: S301 - an exception whose __init__ takes other arguments does not load
    except Exception as exc:  # noqa: BLE001
        data = pickle.dumps((False, RuntimeError(f"{type(out[1]).__name__}: {out[1]}" if not out[0] else
                                                 f"the answer cannot be sent back: {exc}")))
    with os.fdopen(fd, "wb") as fh:
        fh.write(data)


# the fresh interpreter of isolated(..., hash_seed=...): reads the pickled (function, args), answers
FRESH_CHILD = ("import os, pickle, sys\n"
               "from autobal.analysis.run.interrupt import answer\n"
               "with os.fdopen(int(sys.argv[1]), 'rb') as fh:\n"
               "    function, args = pickle.load(fh)\n"
               "answer(function, args, int(sys.argv[2]))\n")


def _failure(function, exc: RuntimeError) -> SolverFailure:
    """The SolverFailure of a CasADi function that raised: its name, the error's last line, and the return flag
    the message quotes (``CV_TOO_MUCH_WORK``) as its status."""
    name = _name(function)
    last = (str(exc).strip().splitlines() or ["(no message)"])[-1][:300]
    flag = re.search(r'"([A-Z][A-Z0-9_]{2,})"', last)
    return SolverFailure(f"{name}: {last}", flag.group(1) if flag else "solver_raised")


def isolated(function, *args, hash_seed: int | None = None):
    """``function(*args)`` in a forked child process, its result (or the exception it raised) sent back pickled.

    For library code that would swallow an interrupt or ignore it for long (ROSS: numba compiles in ctypes
    callbacks, which drop the exception a signal handler raises there, then minutes of Python without a check):
    the parent waits in a read that a signal ends at once, so SIGINT and SIGTERM stop it there; the child, which
    ignores them, is killed then.  What the child prints goes where the parent's output goes (the run's log).
    Without ``os.fork`` (not POSIX) the function runs in this process.

    With ``hash_seed`` the child is a fresh interpreter (the fork executes Python anew) whose ``PYTHONHASHSEED`` is
    that seed: for library code whose arithmetic follows the iteration order of a set of objects hashed by their
    strings (ROSS assembles its matrices over ``set(self.elements)``), so that its numbers are the same on every
    run.  ``function`` must then be importable by name (a module's function); the BLAS thread limit in force here
    (:func:`autobal.run` sets one thread) is the child's too.  Without ``os.fork`` the seed cannot be set: the
    function runs in this process, with its seed.

    Returns
    -------
    What ``function`` returns (picklable).
    """
    if not hasattr(os, "fork"):
        return function(*args)
    check()
    _trace(function)
    read, write = os.pipe()
    job_read, job_write = os.pipe() if hash_seed is not None else (None, None)
    blas_threads = {} if hash_seed is None else _blas_limit()
    pid = os.fork()
    if pid == 0:  # the child: compute, send, leave without running the parent's exit handlers
        code = 1
        try:
            os.close(read)
            for sig in SIGNALS:  # ignored signals stay ignored in an executed program too
                signal.signal(sig, signal.SIG_IGN)
            if hash_seed is None:
                answer(function, args, write)
                code = 0
            else:
                os.close(job_write)
                os.set_inheritable(job_read, True)
                os.set_inheritable(write, True)
                env = os.environ | {"PYTHONHASHSEED": str(hash_seed)} | blas_threads  # as limited here
                os.execve(sys.executable, [sys.executable, "-c", FRESH_CHILD, str(job_read), str(write)], env)
        except BaseException:  # noqa: BLE001 - nothing to send it to
            pass
        finally:
            os._exit(code)
    if hash_seed is not None:
        os.close(job_read)
        try:
            with os.fdopen(job_write, "wb") as fh:
                fh.write(pickle.dumps((function, args)))
        except BaseException:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
            os.close(write)
            os.close(read)
            raise
    os.close(write)
    try:
        with os.fdopen(read, "rb") as fh:
            data = fh.read()  # a signal ends the wait: its handler raises here
    except BaseException:
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
        raise
    _, status = os.waitpid(pid, 0)
    if not data:
        raise SolverFailure(f"{getattr(function, '__name__', 'function')}: its child process ended without an "
                            f"answer (wait status {status})", "child_process_died")
    ok, value = pickle.loads(data)  # noqa: S301 - our own child's answer
    if not ok:
        raise value
    return value

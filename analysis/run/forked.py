"""The second core: work shared with a process forked from this one.

IPOPT serialises every MUMPS call of a process with one lock (``mumps_call_mutex`` in Ipopt 3.14), so two threads
solving NLPs at once take turns at the factorisations: on the spin-up's coarse screening two threads gained
1.03-1.11x, two processes 1.50-1.84x (``python -m benchmarks.spinup_family --screening``; docs/benchmarks.md, "Spin-up
study on a family of problems").  The spin-up study's independent parts (its global search, the coarse screening of its
starts, the ramp baselines: autobal/ocp/solve.py, autobal/ocp/spinup_study.py) therefore run in a process forked
from this one.  A forked process has everything built before the fork (the problem, its NLPs) and nothing built
after; it takes work by index and sends each result back pickled.  Its results are those this process would
compute, bit for bit: a task depends on its index alone.

Nothing of the helper reaches the terminal (its standard output and error go to /dev/null, it draws no bars); what
its solvers print for the run's log comes back with each result and is logged here.  It ends with this process
(Linux's parent-death signal), is killed when the work here stops (an interrupt, an error), and leaves without
running exit handlers.  If it ends without sending a result, the task runs here.  Without fork (not Linux), with
one core, or with the solver option ``parallel.processes`` set to 1, everything runs in this process.
"""

from __future__ import annotations

import contextlib
import ctypes
import multiprocessing
import os
import queue
import signal
import sys
import threading
from collections.abc import Callable

from autobal.analysis.run import progress, solver_options, solver_output

PR_SET_PDEATHSIG = 1  # prctl(2): the signal a process gets when its parent ends


def processes() -> int:
    """How many processes share the work: the solver option ``parallel.processes``, at most the cores this process
    may use; 1 where fork is not available (only Linux forks here).  From a thread other than the main one
    (the explorer's re-optimisation) the fork copies that thread alone, which is all the helper runs."""
    if not sys.platform.startswith("linux"):
        return 1
    return max(1, min(int(solver_options.defaults["parallel.processes"]), len(os.sched_getaffinity(0))))


def shared(fn: Callable, n: int, helper_fn: Callable | None = None) -> list:
    """``[fn(i) for i in range(n)]``, the indices shared with a forked helper process: each process takes the next
    index not taken yet, so a long task on one side does not hold up the rest.  The helper calls ``helper_fn``
    (default ``fn``) instead, e.g. to use solvers of its own.  An exception of a task is raised here."""
    if n < 2 or processes() < 2:
        return [fn(i) for i in range(n)]
    try:
        counter = multiprocessing.get_context("fork").Value("i", 0)
    except OSError:  # no shared memory for the counter (a container without /dev/shm): all here
        return [fn(i) for i in range(n)]

    def take() -> int | None:
        with counter.get_lock():
            i = counter.value
            counter.value += 1
        return i if i < n else None

    out, done = [None] * n, [False] * n
    with _helper(lambda send: _serve(send, helper_fn or fn, take)) as results:
        while (i := take()) is not None:
            out[i], done[i] = fn(i), True
        for i, value in results or ():
            out[i], done[i] = value, True
    return [out[i] if done[i] else fn(i) for i in range(n)]  # what the helper did not send: done here


class Later:
    """``fn()`` computed in a forked process while this one goes on; :meth:`result` waits for its value (or raises its
    exception).  Use it as a context manager: leaving the block ends the helper.  With one process, :meth:`result`
    calls ``fn`` here."""

    def __init__(self, fn: Callable):
        self.fn, self.stack = fn, contextlib.ExitStack()
        self.results = None if processes() < 2 else self.stack.enter_context(
            _helper(lambda send: _serve(send, lambda _: fn(), iter([0, None]).__next__)))

    def result(self):
        if self.results is not None:
            for _, value in self.results:
                return value
        return self.fn()  # one process, or the helper ended without its result

    def __enter__(self) -> Later:
        return self

    def __exit__(self, *exc) -> None:
        self.stack.close()


@contextlib.contextmanager
def _helper(work: Callable):
    """Fork a helper process that runs ``work(send)``; yield the (index, value) pairs it sends, as they come (an
    exception it sends is raised here), or None when no process can be forked (the caller does the work itself).
    On leaving, the helper is killed if it is still running, and reaped."""
    parent = os.getpid()
    try:
        receive, send = multiprocessing.get_context("fork").Pipe(duplex=False)
        pid = os.fork()
    except OSError:  # no process or pipe left (the user's limits)
        yield None
        return
    if pid == 0:  # the helper
        code = 1
        try:
            receive.close()
            _quiet(parent)
            work(send)
            code = 0
        finally:
            os._exit(code)
    send.close()
    # a thread here takes each result off the pipe as it comes: a helper whose result fills the pipe's buffer
    # (a coarse solution, about 100 kB) would otherwise wait for this process to finish its own tasks first
    messages = queue.SimpleQueue()

    def read() -> None:
        while True:
            try:
                messages.put(receive.recv())
            except (EOFError, OSError):  # the helper has ended
                messages.put(None)
                return

    reader = threading.Thread(target=read, daemon=True)
    reader.start()

    def results():
        while (message := messages.get()) is not None:
            i, ok, value, logs = message
            for text in logs:
                solver_output.log(text)
            if not ok:
                raise value
            yield i, value

    try:
        yield results()
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
        reader.join()  # at the end of the pipe now
        receive.close()


def _quiet(parent: int) -> None:
    """In the helper of the process ``parent``: end with it, nothing to the terminal, no bars."""
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None).prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
    if os.getppid() != parent:  # the parent ended before the line above
        os._exit(1)
    null = os.open(os.devnull, os.O_WRONLY)
    os.dup2(null, 1)
    os.dup2(null, 2)
    sys.stdout = sys.stderr = open(os.devnull, "w")  # also where they were not file descriptors 1 and 2
    progress.silence()


def _serve(send, fn: Callable, take: Callable) -> None:
    """In the helper: ``fn(i)`` for each index ``take()`` gives until it gives None, each result sent with what the
    solvers wrote into the run's log meanwhile (an exception: sent as it is, or by its text if it does not
    pickle)."""
    logs = []
    with solver_output.logging_to(logs.append) if solver_output.logging() else contextlib.nullcontext():
        while (i := take()) is not None:
            try:
                record = (i, True, fn(i), logs[:])
            except Exception as exc:  # noqa: BLE001 (raised in the parent)
                record = (i, False, exc, logs[:])
            logs.clear()
            try:
                send.send(record)
            except Exception as exc:  # noqa: BLE001 (an unpicklable result or exception)
                send.send((i, False, RuntimeError(f"the helper process could not send its result: {exc}"), []))
    send.close()

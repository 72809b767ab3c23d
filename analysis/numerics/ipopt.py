"""IPOPT options in one place, and a solve call that reports status and keeps the last iterate.

On a terminal (analysis/run/progress.py: not quiet, not a pipe) a solver gets an iteration callback, and a
solve that runs longer than ``progress.AFTER_S`` draws its own bar: one step per IPOPT iteration, the
objective and the primal infeasibility in its note.  A solver built off a terminal has no callback and
pays nothing.

Every solver writes IPOPT's own log (the iteration table, the exit message) at ``FILE_PRINT_LEVEL`` into a file of
its own (IPOPT's ``output_file``), never onto the terminal (``print_level`` 0); :func:`solve` appends what one
solve wrote, headed by its name, status and iteration count, to the log of the run it belongs to
(:func:`~autobal.analysis.run.solver_output.logging_to`: a context variable, so runs in several threads each get their
own solves).  Nothing of the process (its standard output and error, file descriptors 1 and 2) is redirected.

The OpenBLAS that CasADi brings along (under IPOPT's MUMPS; threadpoolctl does not see it, so ``autobal.run``'s
BLAS limit misses it) is set to one thread as each solver is built, unless the environment sets
``OPENBLAS_NUM_THREADS`` (:func:`one_blas_thread`).
"""

from __future__ import annotations

import atexit
import contextlib
import ctypes
import os
import shutil
import tempfile
import threading
import time
import weakref

import casadi as ca
import numpy as np

from autobal.analysis.run import interrupt, progress, solver_options, solver_output
from autobal.analysis.run.solver_output import log, logging_to  # noqa: F401 (the run log, as before)

# Where IPOPT writes: nothing on the terminal, its log into a file of its own (the options of the solves
# themselves, with their documented defaults, are analysis/run/solver_options.py's)
QUIET = {"ipopt.print_level": 0, "ipopt.sb": "yes", "print_time": False}
FILE_PRINT_LEVEL = 5  # IPOPT's iteration table and exit message in the solver's log file, not on the terminal
OPENBLAS = "libcasadi-tp-openblas.so.0"  # the name MUMPS asks for (CasADi 3.7-3.8 Linux wheels); elsewhere none


def one_blas_thread() -> None:
    """CasADi's own OpenBLAS, the one IPOPT's MUMPS is linked with (``OPENBLAS``), on one thread, unless the environment
    sets ``OPENBLAS_NUM_THREADS``.  On the 2-core machine one thread was faster per IPOPT iteration of the spin-up's
    fine NLPs: 10.7-12.7 ms against 11.5-13.9 ms at 200 intervals, 72-74 ms against 84-87 ms at 800; on its coarse
    ones (50 intervals) it made no difference (docs/benchmarks.md, "Spin-up study on a family of problems")."""
    if "OPENBLAS_NUM_THREADS" in os.environ:
        return
    with contextlib.suppress(OSError, AttributeError):  # RTLD_NOLOAD: the one loaded with IPOPT's plugin, if any
        ctypes.CDLL(OPENBLAS, mode=os.RTLD_NOLOAD | os.RTLD_LAZY).openblas_set_num_threads(1)


NOTE_EVERY_S = 0.2  # the bar's note (objective, infeasibility) is refreshed at most this often, s


class IterationBar(ca.Callback):
    """IPOPT's iteration callback (CasADi's nlpsol option ``iteration_callback``): advances the running
    solve's bar to IPOPT's iteration count with the objective and primal infeasibility as its note, and
    stops IPOPT at the next iteration after an interrupt (the solve then raises Interrupted).

    Parameters
    ----------
    name : str
        The solver's name.
    sizes : dict
        Number of entries of each nlpsol output (x, f, g, lam_x, lam_g, lam_p).
    """

    def __init__(self, name: str, sizes: dict):
        ca.Callback.__init__(self)
        self.sizes, self.solver, self.bar, self.calls, self.next_note = sizes, None, None, 0, 0.0
        self.construct(f"{name}_iterations", {})

    def get_n_in(self):
        return ca.nlpsol_n_out()

    def get_n_out(self):
        return 1

    def get_name_in(self, i):
        return ca.nlpsol_out(i)

    def get_name_out(self, i):
        return "stop"

    def get_sparsity_in(self, i):
        return ca.Sparsity.dense(self.sizes[ca.nlpsol_out(i)], 1)

    def eval(self, arg):
        if interrupt.requested() is not None:
            return [1]  # nonzero: IPOPT stops now (User_Requested_Stop); interrupt.call raises after the call
        if self.bar is not None:
            self.bar.tick(self.calls > 0)  # the first call is IPOPT's iteration 0, the starting point
            self.calls += 1
            now = time.monotonic()
            if now >= self.next_note:  # the solver's statistics cost about as much as the call: now and then
                self.next_note = now + NOTE_EVERY_S
                it = self.solver.stats()["iterations"]
                self.bar.tick(0, f"f {it['obj'][-1]:.6g}, inf_pr {it['inf_pr'][-1]:.1e}")
        return [0]


def nlpsol(name: str, x, p, f, g, warm: bool = False, hess_lag: ca.Function | None = None,
           jac_g: ca.Function | None = None, **extra) -> ca.Function:
    """An IPOPT solver for min f(x; p) s.t. g(x; p) in [lbg, ubg], x in [lbx, ubx], with the options of the
    ``ipopt`` group of :mod:`autobal.analysis.run.solver_options` (and ``ipopt_warm`` when ``warm``), ``extra`` (IPOPT
    option names without the ``ipopt.`` prefix) laid over them.

    ``hess_lag``: a user Hessian of the Lagrangian, (x, p, lam_f, lam_g) -> its upper triangle,
    e.g. the Gauss-Newton lam_f J'J of a least-squares fit (analysis/numerics/least_squares.py).  ``jac_g``: a user
    Jacobian of the constraints, (x, p) -> (g, dg/dx).  Built while bars
    are drawn (a terminal, not quiet), the solver carries an :class:`IterationBar`.
    """
    base = solver_options.get("ipopt") | (solver_options.get("ipopt_warm") if warm else {})
    opts = QUIET | {f"ipopt.{k}": v for k, v in (base | extra).items()}
    if hess_lag is not None:
        opts["hess_lag"] = hess_lag
    if jac_g is not None:
        opts["jac_g"] = jac_g
    log = SolveLog(name)
    opts |= {"ipopt.output_file": log.path, "ipopt.file_print_level": FILE_PRINT_LEVEL}
    bar = None
    if progress.enabled():  # a terminal: long solves show their iterations
        nx, ng, n_p = (int(np.prod(e.shape)) for e in (x, g, p))
        bar = IterationBar(name, {"x": nx, "f": 1, "g": ng, "lam_x": nx, "lam_g": ng, "lam_p": n_p})
        opts["iteration_callback"] = bar
    solver = ca.nlpsol(name, "ipopt", {"x": x, "p": p, "f": f, "g": g}, opts)
    one_blas_thread()  # IPOPT's plugin, and with it MUMPS's OpenBLAS, is loaded now
    if bar is not None:
        solver.autobal_iterations, bar.solver = bar, solver  # the callback lives as long as the solver
    solver.autobal_log = log
    weakref.finalize(solver, log.remove)
    return solver


def solve(solver: ca.Function, **args) -> dict:
    """Call ``solver``; return its outputs as numpy arrays plus status, success, iterations.

    An interrupt (SIGINT, SIGTERM) during the solve raises :class:`autobal.analysis.run.interrupt.Interrupted`
    instead of coming back as a solver status.
    """
    log = getattr(solver, "autobal_log", None)
    with log.solving(solver) if log is not None else contextlib.nullcontext():
        out = _call(solver, args)
        stats = solver.stats()
    res = {k: np.asarray(v).ravel() for k, v in out.items()}
    res["status"] = stats["return_status"]
    res["success"] = bool(stats["success"])
    res["iterations"] = int(stats.get("iter_count", -1))
    progress.tick(note=f"last: {res['iterations']} iterations, {res['status']}")  # a bar counting solves
    return res


def _call(solver: ca.Function, args: dict) -> dict:
    bar = getattr(solver, "autobal_iterations", None)
    if bar is None or not progress.enabled():
        return interrupt.call(solver, **args)
    with progress.steps(None, f"IPOPT {solver.name()}", "iteration", delay=progress.AFTER_S) as bar.bar:
        bar.calls, bar.next_note = 0, 0.0
        try:
            return interrupt.call(solver, **args)
        finally:
            bar.bar = None


_FOLDER = {"path": None}
_FOLDER_LOCK = threading.Lock()


class SolveLog:
    """The file a solver's IPOPT writes its log into (in a temporary folder of this process, removed at exit),
    and the lock that keeps one solve of that solver at a time, so that what a solve wrote is the file's new
    part."""

    def __init__(self, name: str):
        with _FOLDER_LOCK:
            if _FOLDER["path"] is None:
                _FOLDER["path"] = tempfile.mkdtemp(prefix="autobal-ipopt-")
                atexit.register(shutil.rmtree, _FOLDER["path"], True)
        fd, self.path = tempfile.mkstemp(prefix=f"{name}.", suffix=".log", dir=_FOLDER["path"])
        os.close(fd)
        self.lock = threading.Lock()

    @contextlib.contextmanager
    def solving(self, solver: ca.Function):
        """One solve: its part of the file goes to the run's log (:func:`log`) when it ends, also when it raises."""
        with self.lock:
            start = self.size()
            status = "raised"
            try:
                yield
                status = solver.stats().get("return_status", "?")
            finally:
                if solver_output.logging():
                    iterations = solver.stats().get("iter_count", "?") if status != "raised" else "?"
                    log(f"--- IPOPT {solver.name()}: {status}, {iterations} iterations\n{self.read(start)}\n")

    def size(self) -> int:
        try:
            return os.path.getsize(self.path)
        except OSError:
            return 0

    def read(self, start: int) -> str:
        try:
            with open(self.path, errors="backslashreplace") as fh:
                fh.seek(start)
                return fh.read().strip("\n")
        except OSError:
            return ""

    def remove(self) -> None:
        with contextlib.suppress(OSError):
            os.remove(self.path)

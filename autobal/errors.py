"""One exception hierarchy for the toolkit; the CLI maps it to exit codes."""

from __future__ import annotations


class AutobalError(Exception):
    """Base class of every error the toolkit raises on purpose."""


class ScenarioError(AutobalError):
    """Bad input: a scenario or data file that cannot be used (CLI exit code 2)."""


class SolveError(AutobalError):
    """A solver did not converge (CLI exit code 3).

    ``status`` is the solver's own return status and ``last_iterate`` a dict of
    the values it stopped at, kept for inspection.
    """

    def __init__(self, message: str, status: str, last_iterate: dict | None = None):
        super().__init__(f"{message} (solver status: {status})")
        self.message = message
        self.status = status
        self.last_iterate = last_iterate or {}


class SolverFailure(SolveError, RuntimeError):
    """A CasADi solver, integrator or rootfinder that raised instead of returning a status (CVODES'
    ``CV_TOO_MUCH_WORK``, a NaN in a function): a failed solve (CLI exit code 3), and still the
    RuntimeError CasADi raised for the code that handles those (a transient's case records it)."""


class Interrupted(KeyboardInterrupt):
    """The run was stopped by a signal (SIGINT or SIGTERM); the CLI exits with 128 + ``signum``."""

    def __init__(self, signum: int):
        super().__init__(f"interrupted by signal {signum}")
        self.signum = signum

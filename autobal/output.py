"""The life of an output folder, and the solver log.

A run writes into a fresh temporary folder beside the output folder (``.NAME.XXXX.tmp``) and,
when it ends, that folder replaces the output folder whole: so the folder always holds the files
of exactly one run.  What the run leaves:

==============  ==================================================================
completed       ``results.json`` (``"status": "ok"``), CSV tables, PNG figures, ``autobal.log``
failed solve    ``failed_solve.json`` (solver status, last iterate), ``autobal.log``
interrupted     ``interrupted.json`` (the analysis that was running), ``autobal.log``
other error     ``error.json`` (the one-line message), ``autobal.log``
==============  ==================================================================

An existing output folder is replaced (its earlier files are removed) only if it is empty or was
written by autobal (it holds ``autobal.log``); any other folder is refused before anything runs.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import shutil
import sys
import tempfile
import warnings
from pathlib import Path

from autobal.analysis import progress
from autobal.errors import ScenarioError

LOG = "autobal.log"


class OutputFolder:
    """A temporary folder beside ``path`` that replaces ``path`` on :meth:`commit` (or at the end of a
    ``with`` block).

    Raises :class:`~autobal.errors.ScenarioError` at once when ``path`` is a file, a folder that
    autobal did not write, or a place where no folder can be made.
    """

    def __init__(self, path: str | Path):
        self.path = Path(path).expanduser().absolute()
        where = f"output folder {path}"
        if self.path.exists() and not self.path.is_dir():
            raise ScenarioError(f"{where}: exists and is not a folder")
        if self.path.is_dir() and any(self.path.iterdir()) and not (self.path / LOG).exists():
            raise ScenarioError(f"{where}: holds files autobal did not write; give a new or empty folder")
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self.tmp = Path(tempfile.mkdtemp(prefix=f".{self.path.name}.", suffix=".tmp", dir=self.path.parent))
        except OSError as exc:
            raise ScenarioError(f"{where}: cannot be written ({exc.strerror or exc})") from None

    def commit(self) -> Path:
        """Move the temporary folder into place, removing what the output folder held before."""
        old = None
        if self.path.exists():
            old = self.path.with_name(f"{self.tmp.name}.old")
            self.path.rename(old)
        self.tmp.rename(self.path)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
        return self.path

    def discard(self) -> None:
        shutil.rmtree(self.tmp, ignore_errors=True)

    def __enter__(self) -> Path:
        """``with OutputFolder(out) as tmp:`` write into ``tmp``; committed (with its ``autobal.log``) when
        the block ends, discarded when it raises."""
        return self.tmp

    def __exit__(self, kind, exc, tb) -> None:
        if kind is not None:
            self.discard()
            return
        (self.tmp / LOG).touch()
        self.commit()


def _flush_c_stdout() -> None:
    with contextlib.suppress(Exception):
        ctypes.CDLL(None).fflush(None)


class SolverLog:
    """Within ``with SolverLog(path):`` what solvers print (IPOPT, CasADi, CVODES: C-level stdout and
    stderr, Python's stderr) and Python warnings go to ``path``; progress bars still reach the terminal,
    and :meth:`terminal` gives the real stdout back for a moment."""

    def __init__(self, path: str | Path):
        self.path = path

    def __enter__(self):
        sys.stdout.flush()
        sys.stderr.flush()
        _flush_c_stdout()
        self._log = open(self.path, "a")  # noqa: SIM115 (closed in __exit__)
        self._warnings = warnings.catch_warnings()
        self._warnings.__enter__()
        warnings.simplefilter("default")
        warnings.showwarning = lambda msg, cat, fname, line, file=None, text=None: self._log.write(
            warnings.formatwarning(msg, cat, fname, line, text))
        self._saved = os.dup(1)
        self._saved_err = os.dup(2)
        self._py_stderr = sys.stderr
        # progress bars keep the terminal; Python's stderr (tracebacks a solver prints from a callback) and
        # C-level stdout and stderr go to the log
        self._terminal_err = open(os.dup(self._saved_err), "w", buffering=1, errors="backslashreplace")  # noqa: SIM115
        self._bars = progress.output(self._terminal_err)
        self._bars.__enter__()
        sys.stderr = self._log
        os.dup2(self._log.fileno(), 1)
        os.dup2(self._log.fileno(), 2)
        return self

    def __exit__(self, *exc):
        sys.stdout.flush()
        sys.stderr.flush()
        _flush_c_stdout()
        os.dup2(self._saved, 1)
        os.dup2(self._saved_err, 2)
        os.close(self._saved)
        os.close(self._saved_err)
        sys.stderr = self._py_stderr
        self._bars.__exit__(None, None, None)
        self._terminal_err.close()
        self._warnings.__exit__(*exc)
        self._log.close()

    @contextlib.contextmanager
    def terminal(self):
        """The real stdout, for printing inside the block."""
        sys.stdout.flush()
        _flush_c_stdout()
        os.dup2(self._saved, 1)
        try:
            yield
        finally:
            sys.stdout.flush()
            os.dup2(self._log.fileno(), 1)

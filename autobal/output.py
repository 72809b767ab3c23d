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

Runs into the same output folder at the same time need no lock: each writes its own temporary folder,
and the last to finish replaces the folder (:meth:`OutputFolder.commit` renames the old one aside and
removes it, retrying when another run got there first), so the folder ends with the files of exactly
one run and nothing is left beside it.  An output folder given as a symbolic link keeps the link: the
folder it points to is replaced.  SIGINT and SIGTERM that arrive while the folder is moved into place
or removed are held until that is done (:func:`signals_held`), so an interrupt, even a second one, never
leaves a half-moved folder; a temporary folder that no run will commit is removed when the CLI ends
(:func:`discard_uncommitted`).
"""

from __future__ import annotations

import contextlib
import errno
import os
import shutil
import signal
import tempfile
import threading
from pathlib import Path

from autobal.errors import ScenarioError
from autobal.text import clean

LOG = "autobal.log"
SIGNALS = (signal.SIGINT, signal.SIGTERM)
_held: dict = {"pending": None}
_uncommitted: set[OutputFolder] = set()


def _defer(signum, frame) -> None:
    _held["pending"] = _held["pending"] or signum


@contextlib.contextmanager
def signals_held():
    """Within the block SIGINT and SIGTERM are recorded, not acted on; when it ends the first of them
    goes to the handler that was in place (so an interrupt raises there, after the block's work is done).
    In threads other than the main one (which cannot change handlers) the block runs as it is."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {sig: signal.signal(sig, _defer) for sig in SIGNALS}
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        signum, _held["pending"] = _held["pending"], None
        if signum is not None:
            handler = previous[signum]
            if callable(handler):
                handler(signum, None)
            elif handler == signal.SIG_DFL:
                os.kill(os.getpid(), signum)


def umask() -> int:
    """The process's umask (read from /proc where it can be, else set and restored at once)."""
    try:
        with open("/proc/self/status") as fh:
            return int(next(line.split()[1] for line in fh if line.startswith("Umask:")), 8)
    except (OSError, StopIteration, ValueError):
        mask = os.umask(0o022)
        os.umask(mask)
        return mask


def discard_uncommitted() -> None:
    """Remove the temporary folders of this process that no run will commit (the CLI calls it last)."""
    for folder in list(_uncommitted):
        folder.discard()


class OutputFolder:
    """A temporary folder beside ``path`` that replaces ``path`` on :meth:`commit` (or at the end of a
    ``with`` block).

    Raises :class:`~autobal.errors.ScenarioError` at once when ``path`` is a file, a folder that
    autobal did not write, or a place where no folder can be made.
    """

    def __init__(self, path: str | Path):
        where = f"output folder {clean(path)}"
        try:
            self.path = Path(path).expanduser().absolute()
            if self.path.is_symlink():  # the link stays; the folder it points to is replaced
                self.path = Path(os.path.realpath(self.path))
            if self.path.exists() and not self.path.is_dir():
                raise ScenarioError(f"{where}: exists and is not a folder")
            if self.path.is_dir() and any(self.path.iterdir()) and not (self.path / LOG).exists():
                raise ScenarioError(f"{where}: holds files autobal did not write; give a new or empty folder")
            self.path.parent.mkdir(parents=True, exist_ok=True)
            with signals_held():
                self.tmp = Path(tempfile.mkdtemp(prefix=f".{self.path.name}.", suffix=".tmp", dir=self.path.parent))
                _uncommitted.add(self)
            self.tmp.chmod(0o777 & ~umask())  # mkdtemp makes it 0o700; the output folder is made as mkdir makes one
        except OSError as exc:
            raise ScenarioError(f"{where}: cannot be written ({exc.strerror or exc})") from None

    def commit(self) -> Path:
        """Move the temporary folder into place, removing what the output folder held before (also when
        another run put its folder there meanwhile: the last run to commit wins)."""
        with signals_held():
            for _ in range(100):
                try:
                    os.rename(self.tmp, self.path)  # replaces nothing but an empty folder
                    break
                except OSError as exc:
                    if exc.errno not in (errno.ENOTEMPTY, errno.EEXIST):
                        raise
                old = self.path.with_name(f"{self.tmp.name}.old")
                try:
                    os.rename(self.path, old)
                except FileNotFoundError:  # another run moved it aside first
                    continue
                shutil.rmtree(old, ignore_errors=True)
            else:
                self.discard()
                raise ScenarioError(f"output folder {clean(self.path)}: other runs kept replacing it; "
                                    f"this run's files were not moved into place")
            _uncommitted.discard(self)
        return self.path

    def discard(self) -> None:
        with signals_held():
            shutil.rmtree(self.tmp, ignore_errors=True)
            _uncommitted.discard(self)

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


class SolverLog:
    """Within ``with SolverLog(path) as log:`` every IPOPT solve of this thread (its context: runs in other threads
    keep their own logs) appends its iteration log and status to ``path``
    (:func:`autobal.analysis.numerics.ipopt.solve`), and :meth:`write` adds the run's own lines (an analysis' status, a
    failed solve).  Nothing of the process is redirected: standard output and error (file descriptors 1 and 2,
    ``sys.stdout``, ``sys.stderr``), warnings and progress bars stay the caller's."""

    def __init__(self, path: str | Path):
        self.path = path
        self._lock = threading.Lock()

    def __enter__(self):
        from autobal.analysis.numerics import ipopt

        self._log = open(self.path, "a", errors="backslashreplace")  # noqa: SIM115 (closed in __exit__)
        self._logging = ipopt.logging_to(self.write)
        self._logging.__enter__()
        return self

    def __exit__(self, *exc):
        self._logging.__exit__(*exc)
        with self._lock:
            self._log.close()

    def write(self, text: str) -> None:
        """Append ``text`` (a line is ended if it is not) to the log, at once."""
        with self._lock:
            self._log.write(text if text.endswith("\n") else text + "\n")
            self._log.flush()

    @contextlib.contextmanager
    def terminal(self):
        """Print inside the block (the terminal is never taken away: kept for callers that ask for it)."""
        yield

"""Where sweeps and Monte Carlo studies run: in this process (default) or on a dask.distributed cluster.

A study cuts its work into tasks that depend only on their own index (the Monte Carlo draws each
chunk's samples from ``SeedSequence(seed, spawn_key=(chunk,))``), so the same study gives
identical numbers whichever executor runs it and however many workers the cluster has.  A task is
a picklable callable (plain data; CasADi Functions are rebuilt and cached on the worker).

Choice of executor, first given wins: the ``scheduler`` passed to :func:`make`, the run's scheduler
(:func:`using`: the CLI's ``--scheduler ADDRESS`` and ``autobal.run(..., scheduler=...)``), the environment
variable ``AUTOBAL_SCHEDULER``, else in-process.  Never a scene: a scene is data, and a dask scheduler
sends back pickled results that run code in this process, so only the person running autobal names
one.  A progress bar (analysis/run/progress.py: on a terminal, not when quiet) follows runs of more than
one task.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Sequence

from autobal.analysis.run import progress
from autobal.errors import ScenarioError

ENV = "AUTOBAL_SCHEDULER"  # the environment variable naming a dask scheduler
_RUN_SCHEDULER: str | None = None


@contextlib.contextmanager
def using(address: str | None):
    """Within the block, studies run on the dask scheduler at ``address`` (None: as outside the block)."""
    global _RUN_SCHEDULER
    before, _RUN_SCHEDULER = _RUN_SCHEDULER, address or _RUN_SCHEDULER
    try:
        yield
    finally:
        _RUN_SCHEDULER = before


def default_scheduler() -> str | None:
    """The scheduler of the run (:func:`using`), else ``AUTOBAL_SCHEDULER``, else None (in-process)."""
    return _RUN_SCHEDULER or os.environ.get(ENV) or None


def _bar(total: int, desc: str, show: bool):
    return progress.steps(total, desc, "task", show=show and total > 1)


class InProcess:
    """Runs the tasks one after another in this process."""

    name = "in-process"

    def __init__(self, progress: bool = True):
        self.progress = progress

    def map(self, fn: Callable, items: Sequence, desc: str = "") -> list:
        out = []
        with _bar(len(items), desc, self.progress) as bar:
            for item in items:
                out.append(fn(item))
                bar.tick()
        return out

    def close(self) -> None:
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class DaskCluster:
    """Runs the tasks on a dask.distributed scheduler at ``address`` (or an existing ``client``);
    results come back in task order."""

    def __init__(self, address: str | None = None, progress: bool = True, client=None, timeout: str = "10s"):
        try:
            from distributed import Client
        except ImportError:  # pragma: no cover - dask is a dependency
            raise ScenarioError("scheduler: dask.distributed is not installed (pip install 'dask[distributed]')") \
                from None
        self.progress = progress
        self._own = client is None
        if client is None:
            try:
                client = Client(address, timeout=timeout)
            except (OSError, TimeoutError) as exc:
                raise ScenarioError(f"scheduler: cannot reach the dask scheduler at {address!r} (given by --scheduler, "
                                    f"the API or {ENV}): {exc}") from None
        self.client = client
        self.name = f"dask {self.client.scheduler.address}"

    def map(self, fn: Callable, items: Sequence, desc: str = "") -> list:
        from distributed import as_completed

        futures = self.client.map(fn, list(items), pure=False)
        with _bar(len(futures), desc, self.progress) as bar:
            for _ in as_completed(futures):
                bar.tick()
        return self.client.gather(futures)

    def close(self) -> None:
        if self._own:
            self.client.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def make(scheduler: str | None = None, scene_executor=None, progress: bool | None = None):
    """The executor for a study: on ``scheduler``, else :func:`default_scheduler`, else in-process.
    ``scene_executor`` (the scene's ``executor`` block) gives the progress bar's setting only."""
    address = scheduler or default_scheduler()
    if progress is None:
        progress = getattr(scene_executor, "progress", True)
    return DaskCluster(address, progress) if address else InProcess(progress)
